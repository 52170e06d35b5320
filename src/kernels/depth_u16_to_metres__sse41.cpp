// depth_u16_to_metres for SSE4.1 (x86-64 baseline): 8 pixels per step.
// Valid mask on the raw uint16 values: raw != 0 and min(raw, max) == raw (PMINUW is SSE4.1).
#include <smmintrin.h>

#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {

void depth_u16_to_metres__sse41(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                                uint16_t max_valid_raw) {
  const __m128 scale = _mm_set1_ps(metres_per_unit);
  const __m128i max_raw = _mm_set1_epi16(static_cast<short>(max_valid_raw));
  const __m128i zero = _mm_setzero_si128();
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m128i raw = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + i));
    const __m128i in_range = _mm_cmpeq_epi16(_mm_min_epu16(raw, max_raw), raw);
    const __m128i is_zero = _mm_cmpeq_epi16(raw, zero);
    const __m128i valid = _mm_andnot_si128(is_zero, in_range);  // 0xFFFF per valid pixel
    // Widen values (zero-extend) and mask (sign-extend 0xFFFF -> 0xFFFFFFFF) to 32 bits.
    const __m128i lo = _mm_cvtepu16_epi32(raw);
    const __m128i hi = _mm_cvtepu16_epi32(_mm_srli_si128(raw, 8));
    const __m128i mask_lo = _mm_cvtepi16_epi32(valid);
    const __m128i mask_hi = _mm_cvtepi16_epi32(_mm_srli_si128(valid, 8));
    const __m128 m_lo = _mm_mul_ps(_mm_cvtepi32_ps(lo), scale);
    const __m128 m_hi = _mm_mul_ps(_mm_cvtepi32_ps(hi), scale);
    _mm_storeu_ps(dst + i, _mm_and_ps(m_lo, _mm_castsi128_ps(mask_lo)));
    _mm_storeu_ps(dst + i + 4, _mm_and_ps(m_hi, _mm_castsi128_ps(mask_hi)));
  }
  depth_u16_to_metres_ref(src + i, dst + i, n - i, metres_per_unit, max_valid_raw);
}

}  // namespace ef::kernels
