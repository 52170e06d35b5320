// dot_i8 for AVX-512 VNNI (VPDPBUSD on zmm, 64 elements per step, masked tail). Same offset trick as
// dot_i8__avxvnni: sum(a*b) = sum((a XOR 0x80) * b) - 128 * sum(b), exact modulo 2^32 for all inputs.
#include <immintrin.h>

#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

namespace {
int32_t hsum_epi32(__m512i v) {
  const __m256i hi = _mm512_maskz_extracti64x4_epi64(static_cast<__mmask8>(0xFF), v, 1);
  const __m256i lo = _mm512_maskz_extracti64x4_epi64(static_cast<__mmask8>(0xFF), v, 0);
  const __m256i s256 = _mm256_add_epi32(lo, hi);
  __m128i s = _mm_add_epi32(_mm256_castsi256_si128(s256), _mm256_extracti128_si256(s256, 1));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, _MM_SHUFFLE(1, 0, 3, 2)));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, _MM_SHUFFLE(2, 3, 0, 1)));
  return _mm_cvtsi128_si32(s);
}
}  // namespace

int32_t dot_i8__avx512vnni(const int8_t* a, const int8_t* b, std::size_t n) {
  const __m512i bias = _mm512_set1_epi8(static_cast<char>(0x80));
  const __m512i ones = _mm512_set1_epi8(1);
  __m512i acc = _mm512_setzero_si512();
  __m512i sum_b = _mm512_setzero_si512();
  std::size_t i = 0;
  for (; i + 64 <= n; i += 64) {
    const __m512i va = _mm512_loadu_si512(a + i);
    const __m512i vb = _mm512_loadu_si512(b + i);
    acc = _mm512_dpbusd_epi32(acc, _mm512_xor_si512(va, bias), vb);
    sum_b = _mm512_dpbusd_epi32(sum_b, ones, vb);
  }
  if (i < n) {
    // Lanes past the end load as 0 (and are not read): b = 0 there, so they add nothing to either sum.
    const __mmask64 live = (~0ULL) >> (64 - (n - i));
    const __m512i va = _mm512_maskz_loadu_epi8(live, a + i);
    const __m512i vb = _mm512_maskz_loadu_epi8(live, b + i);
    acc = _mm512_dpbusd_epi32(acc, _mm512_xor_si512(va, bias), vb);
    sum_b = _mm512_dpbusd_epi32(sum_b, ones, vb);
  }
  // 128 * sum(b) as a shift by 7 (wrapping like the lanes). The maskz forms with all-ones masks avoid
  // GCC 12's false -Wuninitialized in the plain intrinsics (they merge into _mm512_undefined_*()).
  const __mmask16 all16 = static_cast<__mmask16>(0xFFFF);
  const __m512i total = _mm512_sub_epi32(acc, _mm512_maskz_slli_epi32(all16, sum_b, 7));
  return hsum_epi32(total);
}

}  // namespace ef::kernels
