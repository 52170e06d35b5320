// Scalar reference of dot_i8: the specification. Accumulates in 64 bits and wraps to int32 at the
// end, which equals the SIMD variants' wrapping int32 lane sums (addition mod 2^32 is associative).
#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

int32_t dot_i8_ref(const int8_t* a, const int8_t* b, std::size_t n) {
  int64_t sum = 0;
  for (std::size_t i = 0; i < n; ++i) sum += static_cast<int32_t>(a[i]) * static_cast<int32_t>(b[i]);
  return static_cast<int32_t>(static_cast<uint32_t>(static_cast<uint64_t>(sum)));
}

}  // namespace ef::kernels
