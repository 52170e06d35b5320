// bilateral_row for NEON (AArch64 baseline): 4 output pixels per step in q registers. Separate FMUL /
// FADD (this file turns contraction off, as every kernel); FDIV is the IEEE division.
#include <arm_neon.h>

#include "kernels/bilateral_row_simd.h"

namespace ef::kernels {

namespace {
struct Neon {
  using F = float32x4_t;
  using M = uint32x4_t;
  static constexpr int kWidth = 4;
  static F set1(float x) { return vdupq_n_f32(x); }
  static F load(const float* p) { return vld1q_f32(p); }
  static void store(float* p, F x) { vst1q_f32(p, x); }
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F div(F a, F b) { return vdivq_f32(a, b); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static F keep(M m, F a) { return vreinterpretq_f32_u32(vandq_u32(m, vreinterpretq_u32_f32(a))); }
};
}  // namespace

void bilateral_row__neon(const BilateralRow& b, int width, float* out) { bilateral_row_simd<Neon>(b, width, out); }

}  // namespace ef::kernels
