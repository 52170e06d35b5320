// depth_u16_to_metres at the AVX-512 level (uses F and BW/VL only; see kernels/variants.h for why the
// suffix is avx512vnni): 16 pixels per step, the tail with masked loads and stores.
#include <immintrin.h>

#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {

void depth_u16_to_metres__avx512vnni(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                                     uint16_t max_valid_raw) {
  const __m512 scale = _mm512_set1_ps(metres_per_unit);
  const __m256i max_raw = _mm256_set1_epi16(static_cast<short>(max_valid_raw));
  std::size_t i = 0;
  while (i < n) {
    const std::size_t left = n - i;
    // Lanes past the end are neither read nor written (masked-off lanes never fault).
    const __mmask16 live = left >= 16 ? static_cast<__mmask16>(0xFFFF)
                                      : static_cast<__mmask16>((1u << left) - 1u);
    const __m256i raw = _mm256_maskz_loadu_epi16(live, src + i);
    const __mmask16 valid = _mm256_test_epi16_mask(raw, raw) & _mm256_cmple_epu16_mask(raw, max_raw);
    // The maskz forms with an all-ones mask avoid GCC 12's false -Wmaybe-uninitialized in the plain
    // intrinsics (they pass _mm512_undefined_*() as the merge source).
    const __m512i raw32 = _mm512_maskz_cvtepu16_epi32(static_cast<__mmask16>(0xFFFF), raw);
    const __m512 metres = _mm512_mul_ps(_mm512_maskz_cvtepi32_ps(static_cast<__mmask16>(0xFFFF), raw32), scale);
    // Invalid pixels get +0.0f, as in the reference.
    _mm512_mask_storeu_ps(dst + i, live, _mm512_maskz_mov_ps(valid, metres));
    i += left >= 16 ? 16 : left;
  }
}

}  // namespace ef::kernels
