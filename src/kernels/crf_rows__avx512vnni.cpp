// crf_rows at the AVX-512 level (only F is used; named after the repo's level, see kernels/variants.h):
// one 16-float row is one zmm, so a slice is 7 load-multiply-adds into one register, a splat 7
// read-modify-writes. Separate VMULPS and VADDPS in the reference's order (no FMA); the loops are
// kernels/crf_rows_simd.h.
#include <immintrin.h>

#include "kernels/crf_rows_simd.h"
#include "kernels/f32_ops_avx512.h"

namespace ef::kernels {

const CrfRowsKernel crf_rows__avx512vnni = crf_rows_kernel<F32Avx512>();

}  // namespace ef::kernels
