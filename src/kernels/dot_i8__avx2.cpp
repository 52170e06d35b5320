// dot_i8 for AVX2: sign-extend 16 int8 to int16 (VPMOVSXBW) and VPMADDWD into int32 lanes.
// 32 elements per step, two accumulators.
#include <immintrin.h>

#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

namespace {
int32_t hsum_epi32(__m256i v) {
  __m128i s = _mm_add_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, _MM_SHUFFLE(1, 0, 3, 2)));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, _MM_SHUFFLE(2, 3, 0, 1)));
  return _mm_cvtsi128_si32(s);
}

__m256i madd16(const int8_t* a, const int8_t* b) {
  const __m256i va = _mm256_cvtepi8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)));
  const __m256i vb = _mm256_cvtepi8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(b)));
  return _mm256_madd_epi16(va, vb);  // |lane| <= 32768
}
}  // namespace

int32_t dot_i8__avx2(const int8_t* a, const int8_t* b, std::size_t n) {
  __m256i acc0 = _mm256_setzero_si256();
  __m256i acc1 = _mm256_setzero_si256();
  std::size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    acc0 = _mm256_add_epi32(acc0, madd16(a + i, b + i));
    acc1 = _mm256_add_epi32(acc1, madd16(a + i + 16, b + i + 16));
  }
  if (i + 16 <= n) {
    acc0 = _mm256_add_epi32(acc0, madd16(a + i, b + i));
    i += 16;
  }
  return wrapping_add_i32(hsum_epi32(_mm256_add_epi32(acc0, acc1)), dot_i8_ref(a + i, b + i, n - i));
}

}  // namespace ef::kernels
