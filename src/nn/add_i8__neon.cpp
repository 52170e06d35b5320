// add_i8 at the AArch64 baseline (Advanced SIMD): 16 elements per step. Each step widens the bytes
// to four int32x4 (SXTL), subtracts the zero points, converts to float and computes
// float(a - za) * ma + float(b - zb) * mb with two FMUL and one FADD (vmulq_f32 / vaddq_f32, never
// vmlaq / vfmaq), clamps with FMAX / FMIN, rounds half to even (FCVTNS, vcvtnq_s32_f32), adds the
// output zero point and narrows with saturation (values already in range). Both inputs are loaded
// before the store, so out may alias a or b. The last n mod 16 elements go through add_i8_ref on a
// sub-range view.
#include <arm_neon.h>

#include <cstddef>

#include "nn/eltwise_kernels.h"

namespace ef::nn {

namespace {

struct Consts {
  int32x4_t za, zb, zo;
  float32x4_t ma, mb, lo, hi;
};

int16x4_t quarter(int16x4_t a16, int16x4_t b16, const Consts& k) {
  const float32x4_t ya = vmulq_f32(vcvtq_f32_s32(vsubq_s32(vmovl_s16(a16), k.za)), k.ma);
  const float32x4_t yb = vmulq_f32(vcvtq_f32_s32(vsubq_s32(vmovl_s16(b16), k.zb)), k.mb);
  float32x4_t y = vaddq_f32(ya, yb);
  y = vminq_f32(vmaxq_f32(y, k.lo), k.hi);
  return vqmovn_s32(vaddq_s32(vcvtnq_s32_f32(y), k.zo));
}

}  // namespace

void add_i8__neon(const AddArgs& a) {
  const std::size_t n = std::size_t(a.out.h) * a.out.w * a.out.c;
  Consts k;
  k.za = vdupq_n_s32(a.a.zero_point);
  k.zb = vdupq_n_s32(a.b.zero_point);
  k.zo = vdupq_n_s32(a.out.zero_point);
  k.ma = vdupq_n_f32(a.rq_a.multiplier);
  k.mb = vdupq_n_f32(a.rq_b.multiplier);
  k.lo = vdupq_n_f32(float(a.out_min - a.out.zero_point));
  k.hi = vdupq_n_f32(float(a.out_max - a.out.zero_point));
  const int8_t* pa = a.a.data;
  const int8_t* pb = a.b.data;
  int8_t* po = a.out.data;
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    const int8x16_t va = vld1q_s8(pa + i);
    const int8x16_t vb = vld1q_s8(pb + i);
    const int16x8_t alo = vmovl_s8(vget_low_s8(va)), ahi = vmovl_s8(vget_high_s8(va));
    const int16x8_t blo = vmovl_s8(vget_low_s8(vb)), bhi = vmovl_s8(vget_high_s8(vb));
    const int16x8_t r0 = vcombine_s16(quarter(vget_low_s16(alo), vget_low_s16(blo), k),
                                      quarter(vget_high_s16(alo), vget_high_s16(blo), k));
    const int16x8_t r1 = vcombine_s16(quarter(vget_low_s16(ahi), vget_low_s16(bhi), k),
                                      quarter(vget_high_s16(ahi), vget_high_s16(bhi), k));
    vst1q_s8(po + i, vcombine_s8(vqmovn_s16(r0), vqmovn_s16(r1)));
  }
  add_i8_ref_range(a, i, n);
}

}  // namespace ef::nn
