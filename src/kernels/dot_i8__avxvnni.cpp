// dot_i8 for AVX-VNNI (VEX VPDPBUSD on ymm, 32 elements per step).
// VPDPBUSD multiplies unsigned by signed bytes. With a' = a + 128 = a XOR 0x80 (0..255):
//   sum(a*b) = sum(a'*b) - 128 * sum(b)
// sum(b) comes from a second VPDPBUSD with all-ones. Both are exact for every input including -128:
// each VPDPBUSD lane adds four products of magnitude <= 255*128 to a wrapping int32, so the result
// is the true sum modulo 2^32, like the reference.
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
}  // namespace

int32_t dot_i8__avxvnni(const int8_t* a, const int8_t* b, std::size_t n) {
  const __m256i bias = _mm256_set1_epi8(static_cast<char>(0x80));
  const __m256i ones = _mm256_set1_epi8(1);
  __m256i acc = _mm256_setzero_si256();    // sum(a' * b) per lane
  __m256i sum_b = _mm256_setzero_si256();  // sum(b) per lane
  std::size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    const __m256i va = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a + i));
    const __m256i vb = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b + i));
    acc = _mm256_dpbusd_avx_epi32(acc, _mm256_xor_si256(va, bias), vb);
    sum_b = _mm256_dpbusd_avx_epi32(sum_b, ones, vb);
  }
  // 128 * sum(b) as a left shift by 7 (wrapping, like the lane arithmetic).
  const __m256i total = _mm256_sub_epi32(acc, _mm256_slli_epi32(sum_b, 7));
  return wrapping_add_i32(hsum_epi32(total), dot_i8_ref(a + i, b + i, n - i));
}

}  // namespace ef::kernels
