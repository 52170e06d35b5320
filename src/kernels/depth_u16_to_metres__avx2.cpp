// depth_u16_to_metres for AVX2: 16 pixels per step (two 8-lane float vectors).
#include <immintrin.h>

#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {

void depth_u16_to_metres__avx2(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                               uint16_t max_valid_raw) {
  const __m256 scale = _mm256_set1_ps(metres_per_unit);
  // Compare in 32 bits after zero-extension: the values are < 2^16 so signed compares are exact.
  const __m256i max_raw = _mm256_set1_epi32(max_valid_raw);
  const __m256i zero = _mm256_setzero_si256();
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    for (int half = 0; half < 2; ++half) {
      const __m128i raw16 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + i + 8 * half));
      const __m256i raw = _mm256_cvtepu16_epi32(raw16);
      const __m256i invalid = _mm256_or_si256(_mm256_cmpeq_epi32(raw, zero), _mm256_cmpgt_epi32(raw, max_raw));
      const __m256 metres = _mm256_mul_ps(_mm256_cvtepi32_ps(raw), scale);
      _mm256_storeu_ps(dst + i + 8 * half, _mm256_andnot_ps(_mm256_castsi256_ps(invalid), metres));
    }
  }
  depth_u16_to_metres_ref(src + i, dst + i, n - i, metres_per_unit, max_valid_raw);
}

}  // namespace ef::kernels
