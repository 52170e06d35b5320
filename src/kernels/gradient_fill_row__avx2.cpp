// gradient_fill_row for AVX2: 8 pixels per step in ymm registers (separate multiply and add:
// contraction off, although the file is built with -mfma).
#include <immintrin.h>

#include "kernels/f32_ops_avx2.h"
#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

void gradient_fill_row__avx2(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                             float* filled) {
  gradient_fill_row_simd<F32Avx2>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
