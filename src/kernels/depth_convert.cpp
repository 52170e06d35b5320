// TEMPORARY scalar-only body so other modules build; the kernels helper replaces this file with
// the dispatched variants.
#include "kernels/depth_convert.h"

namespace ef::kernels {
void depth_u16_to_metres(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                         uint16_t max_valid_raw) {
  for (std::size_t i = 0; i < n; ++i) {
    const uint16_t v = src[i];
    dst[i] = (v == 0 || v > max_valid_raw) ? 0.0f : static_cast<float>(v) * metres_per_unit;
  }
}
}  // namespace ef::kernels
