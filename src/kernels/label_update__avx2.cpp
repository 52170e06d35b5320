// label_update for AVX2: two surfels per ymm (one per 128-bit lane), the byte minimum reduced within
// each lane by byte shifts. Pairs are applied two at a time, so a surfel listed twice in a row is
// handled one pair at a time to keep the reference's order.
#include <immintrin.h>

#include "kernels/label_update_variants.h"

namespace ef::kernels {

// Prefetch distance (pairs): the surfels are random rows of a store far larger than the caches.
static constexpr std::size_t kPrefetch = 16;

void label_update__avx2(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n) {
  const __m128i keep128 = _mm_setr_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 0);
  const __m256i keep = _mm256_broadcastsi128_si256(keep128);
  const __m256i zero = _mm256_setzero_si256();
  std::size_t i = 0;
  for (; i + 2 <= n; i += 2) {
    if (i + kPrefetch + 0 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 0].surfel) * kLabelUpdateBytes, 1);
    if (i + kPrefetch + 1 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 1].surfel) * kLabelUpdateBytes, 1);
    if (pairs[i].surfel == pairs[i + 1].surfel) {  // dependent pair: one at a time
      label_update_ref(store, obs, pairs + i, 2);
      continue;
    }
    uint8_t* s0 = store + std::size_t(pairs[i].surfel) * kLabelUpdateBytes;
    uint8_t* s1 = store + std::size_t(pairs[i + 1].surfel) * kLabelUpdateBytes;
    const uint8_t* o0 = obs + std::size_t(pairs[i].observation) * kLabelUpdateBytes;
    const uint8_t* o1 = obs + std::size_t(pairs[i + 1].observation) * kLabelUpdateBytes;
    const __m256i sv = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(s0))),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(s1)), 1);
    const __m256i ov = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(o0))),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(o1)), 1);
    const __m256i t = _mm256_adds_epu8(sv, ov);
    __m256i m = _mm256_min_epu8(t, _mm256_srli_si256(t, 8));
    m = _mm256_min_epu8(m, _mm256_srli_si256(m, 4));
    m = _mm256_min_epu8(m, _mm256_srli_si256(m, 2));
    m = _mm256_min_epu8(m, _mm256_srli_si256(m, 1));
    m = _mm256_shuffle_epi8(m, zero);  // byte 0 of each lane to the whole lane
    const __m256i r = _mm256_and_si256(_mm256_sub_epi8(t, m), keep);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(s0), _mm256_castsi256_si128(r));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(s1), _mm256_extracti128_si256(r, 1));
  }
  label_update_ref(store, obs, pairs + i, n - i);
}

}  // namespace ef::kernels
