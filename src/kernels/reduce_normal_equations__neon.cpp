// reduce_normal_equations for NEON (AArch64 baseline): 4 lanes per q register, so each of the 8 lanes
// of the specification is visited in two halves; two passes of 14 accumulators fit the 32 registers.
// Separate FMUL / FADD: AArch64 always has FMLA, and the compiler would fuse them if contraction were
// on, which would change the rounding (this file turns it off).
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/reduce_normal_equations_simd.h"

namespace ef::kernels {

namespace {
struct Neon : F32Neon {
  static void add_to_totals(double* t, F v) {
    vst1q_f64(t, vaddq_f64(vld1q_f64(t), vcvt_f64_f32(vget_low_f32(v))));
    vst1q_f64(t + 2, vaddq_f64(vld1q_f64(t + 2), vcvt_high_f64_f32(v)));
  }
};
}  // namespace

void reduce_normal_equations__neon(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  ne_reduce_simd<Neon, NePass<Neon, 0, 1, 6>, NePass<Neon, 2, 3, 4, 5>>(rows, stride, n, out);
}

}  // namespace ef::kernels
