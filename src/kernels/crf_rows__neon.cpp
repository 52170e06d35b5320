// crf_rows for AArch64 Advanced SIMD: one 16-float row is four q registers. FMUL then FADD in the
// reference's order (never FMLA, which rounds once: kernels build with -ffp-contract=off, and the
// intrinsics below are the unfused ones); the loops are kernels/crf_rows_simd.h.
#include <arm_neon.h>

#include "kernels/crf_rows_simd.h"
#include "kernels/f32_ops_neon.h"

namespace ef::kernels {

const CrfRowsKernel crf_rows__neon = crf_rows_kernel<F32Neon>();

}  // namespace ef::kernels
