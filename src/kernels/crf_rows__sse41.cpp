// crf_rows for SSE4.1 (the x86-64 baseline): one 16-float row is four xmm, separate MULPS and ADDPS
// in the reference's order; the loops are kernels/crf_rows_simd.h.
#include <smmintrin.h>

#include "kernels/crf_rows_simd.h"
#include "kernels/f32_ops_sse41.h"

namespace ef::kernels {

const CrfRowsKernel crf_rows__sse41 = crf_rows_kernel<F32Sse41>();

}  // namespace ef::kernels
