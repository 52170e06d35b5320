// gradient_fill_row for AVX2: 8 pixels per step in ymm registers (separate multiply and add:
// contraction off, although the file is built with -mfma).
#include <immintrin.h>

#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

namespace {
struct Avx2 {
  using F = __m256;
  using M = __m256;
  static constexpr int kWidth = 8;
  static F set1(float x) { return _mm256_set1_ps(x); }
  static F load(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, F x) { _mm256_storeu_ps(p, x); }
  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static M gt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  static F select(M m, F a, F b) { return _mm256_blendv_ps(b, a, m); }
};
}  // namespace

void gradient_fill_row__avx2(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                             float* filled) {
  gradient_fill_row_simd<Avx2>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
