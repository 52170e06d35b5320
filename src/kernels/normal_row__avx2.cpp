// normal_row for AVX2: 8 pixels per step in ymm registers (separate multiply and add: contraction
// off, although the file is built with -mfma). Each half of 4 pixels is de-interleaved (and
// interleaved to store) as the SSE4.1 variant does, with blends and a shuffle.
#include <immintrin.h>

#include <cstdint>

#include "kernels/normal_row_simd.h"

namespace ef::kernels {

namespace {
struct Avx2 {
  using F = __m256;
  using M = __m256;
  static constexpr int kWidth = 8;
  static F set1(float x) { return _mm256_set1_ps(x); }
  // Four pixels: a = x0 y0 z0 x1, b = y1 z1 x2 y2, c = z2 x3 y3 z3.
  static void load3_half(const float* p, __m128& x, __m128& y, __m128& z) {
    const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), c = _mm_loadu_ps(p + 8);
    const __m128 mx = _mm_blend_ps(_mm_blend_ps(a, b, 0x4), c, 0x2);  // x0 x3 x2 x1
    const __m128 my = _mm_blend_ps(_mm_blend_ps(a, b, 0x9), c, 0x4);  // y1 y0 y3 y2
    const __m128 mz = _mm_blend_ps(_mm_blend_ps(a, b, 0x2), c, 0x9);  // z2 z1 z0 z3
    x = _mm_shuffle_ps(mx, mx, _MM_SHUFFLE(1, 2, 3, 0));
    y = _mm_shuffle_ps(my, my, _MM_SHUFFLE(2, 3, 0, 1));
    z = _mm_shuffle_ps(mz, mz, _MM_SHUFFLE(3, 0, 1, 2));
  }
  static void store3_half(float* p, __m128 x, __m128 y, __m128 z) {
    const __m128 mx = _mm_shuffle_ps(x, x, _MM_SHUFFLE(1, 2, 3, 0));
    const __m128 my = _mm_shuffle_ps(y, y, _MM_SHUFFLE(2, 3, 0, 1));
    const __m128 mz = _mm_shuffle_ps(z, z, _MM_SHUFFLE(3, 0, 1, 2));
    _mm_storeu_ps(p, _mm_blend_ps(_mm_blend_ps(mx, my, 0x2), mz, 0x4));
    _mm_storeu_ps(p + 4, _mm_blend_ps(_mm_blend_ps(my, mz, 0x2), mx, 0x4));
    _mm_storeu_ps(p + 8, _mm_blend_ps(_mm_blend_ps(mz, mx, 0x2), my, 0x4));
  }
  static void load3(const float* p, F& x, F& y, F& z) {
    __m128 x0, y0, z0, x1, y1, z1;
    load3_half(p, x0, y0, z0);
    load3_half(p + 12, x1, y1, z1);
    x = _mm256_set_m128(x1, x0);
    y = _mm256_set_m128(y1, y0);
    z = _mm256_set_m128(z1, z0);
  }
  static void store3(float* p, F x, F y, F z) {
    store3_half(p, _mm256_castps256_ps128(x), _mm256_castps256_ps128(y), _mm256_castps256_ps128(z));
    store3_half(p + 12, _mm256_extractf128_ps(x, 1), _mm256_extractf128_ps(y, 1), _mm256_extractf128_ps(z, 1));
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
