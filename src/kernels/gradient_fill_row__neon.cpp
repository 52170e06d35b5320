// gradient_fill_row for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as
// all-ones uint32 lanes. Separate FMUL / FADD (this file turns contraction off, as every kernel).
#include <arm_neon.h>

#include "kernels/gradient_fill_row_simd.h"

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
  static F select(M m, F a, F b) { return vbslq_f32(m, a, b); }
};
}  // namespace

void gradient_fill_row__neon(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                             float* filled) {
  gradient_fill_row_simd<Neon>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
