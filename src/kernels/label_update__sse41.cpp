// label_update for SSE4.1: one surfel per xmm; the horizontal byte minimum by pairing bytes into
// 16-bit lanes and PHMINPOSUW.
#include <smmintrin.h>

#include "kernels/label_update_variants.h"

namespace ef::kernels {

// Prefetch distance (pairs): the surfels are random rows of a store far larger than the caches.
static constexpr std::size_t kPrefetch = 16;

void label_update__sse41(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n) {
  // Keeps classes 0..13, clears the two reserved bytes.
  const __m128i keep = _mm_setr_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 0);
  const __m128i low_bytes = _mm_set1_epi16(0x00FF);
  const __m128i zero = _mm_setzero_si128();
  for (std::size_t i = 0; i < n; ++i) {
    if (i + kPrefetch + 0 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 0].surfel) * kLabelUpdateBytes, 1);
    __m128i* s = reinterpret_cast<__m128i*>(store + std::size_t(pairs[i].surfel) * kLabelUpdateBytes);
    const __m128i* o = reinterpret_cast<const __m128i*>(obs + std::size_t(pairs[i].observation) * kLabelUpdateBytes);
    const __m128i t = _mm_adds_epu8(_mm_loadu_si128(s), _mm_loadu_si128(o));
    // Bytes 14, 15 are 255 (the observation's spare bytes), so the min over 16 bytes is the class min.
    const __m128i pair_min = _mm_and_si128(_mm_min_epu8(t, _mm_srli_epi16(t, 8)), low_bytes);
    const __m128i m = _mm_shuffle_epi8(_mm_minpos_epu16(pair_min), zero);  // broadcast byte 0
    _mm_storeu_si128(s, _mm_and_si128(_mm_sub_epi8(t, m), keep));
  }
}

}  // namespace ef::kernels
