// normal_row for AVX2: 8 pixels per step in ymm registers (separate multiply and add: contraction
// off, although the file is built with -mfma). Each half of 4 pixels is de-interleaved (and
// interleaved to store) as the SSE4.1 variant does (kernels/xyz4_sse.h).
#include <immintrin.h>

#include <cstdint>

#include "kernels/normal_row_simd.h"
#include "kernels/xyz4_sse.h"

namespace ef::kernels {

namespace {
struct Avx2 {
  using F = __m256;
  using M = __m256;
  static constexpr int kWidth = 8;
  static F set1(float x) { return _mm256_set1_ps(x); }
  static void load3(const float* p, F& x, F& y, F& z) {
    __m128 x0, y0, z0, x1, y1, z1;
    load_xyz4(p, x0, y0, z0);
    load_xyz4(p + 12, x1, y1, z1);
    x = _mm256_set_m128(x1, x0);
    y = _mm256_set_m128(y1, y0);
    z = _mm256_set_m128(z1, z0);
  }
  static void store3(float* p, F x, F y, F z) {
    store_xyz4(p, _mm256_castps256_ps128(x), _mm256_castps256_ps128(y), _mm256_castps256_ps128(z));
    store_xyz4(p + 12, _mm256_extractf128_ps(x, 1), _mm256_extractf128_ps(y, 1), _mm256_extractf128_ps(z, 1));
  }
  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static F sqrt(F a) { return _mm256_sqrt_ps(a); }
  static F abs(F a) { return _mm256_and_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(INT32_MAX))); }
  static M gt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  static M le(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  static M land(M a, M b) { return _mm256_and_ps(a, b); }
  static F select(M m, F a, F b) { return _mm256_blendv_ps(b, a, m); }
};
}  // namespace

void normal_row__avx2(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Avx2>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
