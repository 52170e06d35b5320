// bilateral_row for AVX2: 8 output pixels per step in ymm registers (separate multiply and add:
// contraction off, although the file is built with -mfma).
#include <immintrin.h>

#include "kernels/bilateral_row_simd.h"
#include "kernels/f32_ops_avx2.h"

namespace ef::kernels {

void bilateral_row__avx2(const BilateralRow& b, int width, float* out) { bilateral_row_simd<F32Avx2>(b, width, out); }

}  // namespace ef::kernels
