// bilateral_row for AVX2: 8 output pixels per step in ymm registers (separate multiply and add:
// contraction off, although the file is built with -mfma).
#include <immintrin.h>

#include "kernels/bilateral_row_simd.h"

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
  static F keep(M m, F a) { return _mm256_and_ps(m, a); }
};
}  // namespace

void bilateral_row__avx2(const BilateralRow& b, int width, float* out) { bilateral_row_simd<Avx2>(b, width, out); }

}  // namespace ef::kernels
