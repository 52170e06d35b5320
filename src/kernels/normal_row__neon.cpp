// normal_row for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes; LD3 / ST3 de-interleave and interleave the three components. Separate FMUL / FADD
// (this file turns contraction off, as every kernel); FDIV and FSQRT are the IEEE operations.
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/normal_row_simd.h"

namespace ef::kernels {

void normal_row__neon(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<F32Neon>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
