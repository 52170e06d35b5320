// label_update at the AVX-512 level (only F and BW are used; named after the repo's level, see
// kernels/variants.h): four surfels per zmm, one per 128-bit lane. A group of four that names one
// surfel twice goes through the reference one pair at a time, keeping the reference's order.
#include <immintrin.h>

#include "kernels/label_update_variants.h"

namespace ef::kernels {

// Prefetch distance (pairs): the surfels are random rows of a store far larger than the caches.
static constexpr std::size_t kPrefetch = 16;

static bool distinct4(const LabelUpdatePair* p) {
  return p[0].surfel != p[1].surfel && p[0].surfel != p[2].surfel && p[0].surfel != p[3].surfel &&
         p[1].surfel != p[2].surfel && p[1].surfel != p[3].surfel && p[2].surfel != p[3].surfel;
}

static __m128i load16(const uint8_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }

void label_update__avx512vnni(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n) {
  // Byte mask: classes 0..13 of each lane kept, the two reserved bytes cleared.
  const __mmask64 keep = 0x3FFF3FFF3FFF3FFFull;
  const __m512i zero = _mm512_setzero_si512();
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    if (i + kPrefetch + 0 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 0].surfel) * kLabelUpdateBytes, 1);
    if (i + kPrefetch + 1 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 1].surfel) * kLabelUpdateBytes, 1);
    if (i + kPrefetch + 2 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 2].surfel) * kLabelUpdateBytes, 1);
    if (i + kPrefetch + 3 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 3].surfel) * kLabelUpdateBytes, 1);
    const LabelUpdatePair* p = pairs + i;
    if (!distinct4(p)) {
      label_update_ref(store, obs, p, 4);
      continue;
    }
    uint8_t* s[4];
    const uint8_t* o[4];
    for (int k = 0; k < 4; ++k) {
      s[k] = store + std::size_t(p[k].surfel) * kLabelUpdateBytes;
      o[k] = obs + std::size_t(p[k].observation) * kLabelUpdateBytes;
    }
    __m512i sv = _mm512_zextsi128_si512(load16(s[0]));
    sv = _mm512_inserti32x4(sv, load16(s[1]), 1);
    sv = _mm512_inserti32x4(sv, load16(s[2]), 2);
    sv = _mm512_inserti32x4(sv, load16(s[3]), 3);
    __m512i ov = _mm512_zextsi128_si512(load16(o[0]));
    ov = _mm512_inserti32x4(ov, load16(o[1]), 1);
    ov = _mm512_inserti32x4(ov, load16(o[2]), 2);
    ov = _mm512_inserti32x4(ov, load16(o[3]), 3);
    const __m512i t = _mm512_adds_epu8(sv, ov);
    __m512i m = _mm512_min_epu8(t, _mm512_bsrli_epi128(t, 8));
    m = _mm512_min_epu8(m, _mm512_bsrli_epi128(m, 4));
    m = _mm512_min_epu8(m, _mm512_bsrli_epi128(m, 2));
    m = _mm512_min_epu8(m, _mm512_bsrli_epi128(m, 1));
    m = _mm512_shuffle_epi8(m, zero);  // byte 0 of each lane to the whole lane
    const __m512i r = _mm512_maskz_sub_epi8(keep, t, m);
    // Through memory: GCC 12's lane-extract intrinsics trip -Werror=maybe-uninitialized.
    alignas(64) uint8_t lanes[64];
    _mm512_store_si512(lanes, r);
    for (int k = 0; k < 4; ++k)
      _mm_storeu_si128(reinterpret_cast<__m128i*>(s[k]), _mm_load_si128(reinterpret_cast<const __m128i*>(lanes + 16 * k)));
  }
  label_update_ref(store, obs, pairs + i, n - i);
}

}  // namespace ef::kernels
