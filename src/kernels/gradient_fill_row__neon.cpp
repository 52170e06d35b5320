// gradient_fill_row for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as
// all-ones uint32 lanes. Separate FMUL / FADD (this file turns contraction off, as every kernel).
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

void gradient_fill_row__neon(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                             float* filled) {
  gradient_fill_row_simd<F32Neon>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
