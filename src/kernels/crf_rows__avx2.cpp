// crf_rows for AVX2: one 16-float row is two ymm, separate VMULPS and VADDPS in the reference's order
// (no FMA, although this level has it); the loops are kernels/crf_rows_simd.h.
#include <immintrin.h>

#include "kernels/crf_rows_simd.h"
#include "kernels/f32_ops_avx2.h"

namespace ef::kernels {

const CrfRowsKernel crf_rows__avx2 = crf_rows_kernel<F32Avx2>();

}  // namespace ef::kernels
