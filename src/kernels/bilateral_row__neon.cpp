// bilateral_row for NEON (AArch64 baseline): 4 output pixels per step in q registers. Separate FMUL /
// FADD (this file turns contraction off, as every kernel); FDIV is the IEEE division.
#include <arm_neon.h>

#include "kernels/bilateral_row_simd.h"
#include "kernels/f32_ops_neon.h"

namespace ef::kernels {

void bilateral_row__neon(const BilateralRow& b, int width, float* out) { bilateral_row_simd<F32Neon>(b, width, out); }

}  // namespace ef::kernels
