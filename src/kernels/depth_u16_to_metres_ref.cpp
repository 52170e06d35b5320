// Scalar reference of depth_u16_to_metres: the specification every SIMD variant must match bit for
// bit. One IEEE single-precision multiply per valid pixel; there is no addition, so no compiler can
// contract it into an FMA and every variant rounds identically. Invalid pixels are +0.0f.
#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {

void depth_u16_to_metres_ref(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                             uint16_t max_valid_raw) {
  for (std::size_t i = 0; i < n; ++i) {
    const uint16_t raw = src[i];
    // uint16 -> float is exact (values < 2^24).
    dst[i] = (raw == 0 || raw > max_valid_raw) ? 0.0f : static_cast<float>(raw) * metres_per_unit;
  }
}

}  // namespace ef::kernels
