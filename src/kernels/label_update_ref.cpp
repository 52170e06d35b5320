// Scalar reference of label_update: the specification every SIMD variant must match byte for byte.
#include "kernels/label_update_variants.h"

namespace ef::kernels {

void label_update_ref(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    uint8_t* s = store + std::size_t(pairs[i].surfel) * kLabelUpdateBytes;
    const uint8_t* o = obs + std::size_t(pairs[i].observation) * kLabelUpdateBytes;
    unsigned t[kLabelUpdateClasses];
    unsigned m = 255;
    for (int c = 0; c < kLabelUpdateClasses; ++c) {
      const unsigned sum = unsigned(s[c]) + unsigned(o[c]);  // log-space product
      t[c] = sum > 255 ? 255 : sum;                          // saturating
      if (t[c] < m) m = t[c];
    }
    for (int c = 0; c < kLabelUpdateClasses; ++c) s[c] = static_cast<uint8_t>(t[c] - m);  // normalise
    s[14] = 0;  // reserved bytes stay 0
    s[15] = 0;
  }
}

}  // namespace ef::kernels
