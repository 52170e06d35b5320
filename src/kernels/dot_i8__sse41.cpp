// dot_i8 for SSE4.1: sign-extend to int16 (PMOVSXBW) and multiply-add pairs into int32 (PMADDWD).
// PMADDUBSW is not used: it is unsigned x signed and saturates to int16, so it is not exact for
// signed x signed inputs. 16 elements per step.
#include <smmintrin.h>

#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

namespace {
int32_t hsum_epi32(__m128i v) {
  v = _mm_add_epi32(v, _mm_shuffle_epi32(v, _MM_SHUFFLE(1, 0, 3, 2)));
  v = _mm_add_epi32(v, _mm_shuffle_epi32(v, _MM_SHUFFLE(2, 3, 0, 1)));
  return _mm_cvtsi128_si32(v);
}
}  // namespace

int32_t dot_i8__sse41(const int8_t* a, const int8_t* b, std::size_t n) {
  __m128i acc = _mm_setzero_si128();
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a + i));
    const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + i));
    // Each PMADDWD lane is at most 2 * 128 * 128 = 32768 in magnitude: no overflow.
    const __m128i lo = _mm_madd_epi16(_mm_cvtepi8_epi16(va), _mm_cvtepi8_epi16(vb));
    const __m128i hi = _mm_madd_epi16(_mm_cvtepi8_epi16(_mm_srli_si128(va, 8)),
                                      _mm_cvtepi8_epi16(_mm_srli_si128(vb, 8)));
    acc = _mm_add_epi32(acc, _mm_add_epi32(lo, hi));
  }
  return wrapping_add_i32(hsum_epi32(acc), dot_i8_ref(a + i, b + i, n - i));
}

}  // namespace ef::kernels
