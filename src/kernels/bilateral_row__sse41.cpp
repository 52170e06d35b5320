// bilateral_row for SSE4.1 (the x86-64 baseline): 4 output pixels per step in xmm registers.
#include <smmintrin.h>

#include "kernels/bilateral_row_simd.h"
#include "kernels/f32_ops_sse41.h"

namespace ef::kernels {

void bilateral_row__sse41(const BilateralRow& b, int width, float* out) { bilateral_row_simd<F32Sse41>(b, width, out); }

}  // namespace ef::kernels
