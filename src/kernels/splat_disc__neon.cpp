// splat_disc for NEON (AArch64): 4 pixels of a row per step (see kernels/splat_disc.h for the
// contract). Separate vmulq / vaddq (contraction off), so no FMA is formed. vminq_f32 returns NaN
// where the reference's std::min returns the other operand, but only where denom is NaN, where the
// pixel never wins (denom < 0 is false), so the buffers are the same.
#include <arm_neon.h>

#include <cstddef>

#include "kernels/splat_disc_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void splat_disc__neon(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner,
                      int width) {
  constexpr int kW = 4;
  if (width < kW) {
    splat_disc_ref(d, ray_x, ray_y, key, winner, width);
    return;
  }
  const float32x4_t nx = vdupq_n_f32(d.nx), xc = vdupq_n_f32(d.xc), yc = vdupq_n_f32(d.yc), zc = vdupq_n_f32(d.zc);
  const float32x4_t np = vdupq_n_f32(d.np), r2 = vdupq_n_f32(d.r2), tie = vdupq_n_f32(d.tie);
  const float32x4_t near = vdupq_n_f32(d.near), lim = vdupq_n_f32(-1e-12f), zero = vdupq_n_f32(0.0f);
  const int32x4_t sid = vdupq_n_s32(d.id);
  static const int32_t kIota[4] = {0, 1, 2, 3};
  const int32x4_t iota = vld1q_s32(kIota), last = vdupq_n_s32(d.x1);
  for (int y = d.y0; y <= d.y1; ++y) {
    const float dys = ray_y[y];
    const float32x4_t dy = vdupq_n_f32(dys);
    const float32x4_t row_term = vdupq_n_f32(d.ny * dys + d.nz);
    float* zrow = key + static_cast<std::size_t>(y) * width;
    int32_t* idrow = winner + static_cast<std::size_t>(y) * width;
    for (int cur = d.x0; cur <= d.x1; cur += kW) {
      const int s = cur < width - kW ? cur : width - kW;  // the chunk ends at the border at the latest
      const int32x4_t xs = vaddq_s32(vdupq_n_s32(s), iota);
      const uint32x4_t inside = vandq_u32(vcleq_s32(vdupq_n_s32(cur), xs), vcleq_s32(xs, last));
      const float32x4_t dx = vld1q_f32(ray_x + s);
      const float32x4_t denom = vaddq_f32(vmulq_f32(nx, dx), row_term);
      const float32x4_t z = vdivq_f32(np, vminq_f32(lim, denom));
      const float32x4_t ex = vsubq_f32(vmulq_f32(dx, z), xc);
      const float32x4_t ey = vsubq_f32(vmulq_f32(dy, z), yc);
      const float32x4_t ez = vsubq_f32(z, zc);
      const float32x4_t e2 = vaddq_f32(vaddq_f32(vmulq_f32(ex, ex), vmulq_f32(ey, ey)), vmulq_f32(ez, ez));
      const float32x4_t k = vaddq_f32(z, vmulq_f32(vmulq_f32(z, tie), e2));
      const float32x4_t old_k = vld1q_f32(zrow + s);
      uint32x4_t wins = vandq_u32(vcltq_f32(denom, zero), vcleq_f32(e2, r2));
      wins = vandq_u32(wins, vandq_u32(vcgeq_f32(z, near), vcltq_f32(k, old_k)));
      wins = vandq_u32(wins, inside);
      vst1q_f32(zrow + s, vbslq_f32(wins, k, old_k));
      vst1q_s32(idrow + s, vbslq_s32(wins, sid, vld1q_s32(idrow + s)));
    }
  }
}

}  // namespace ef::kernels
