// Dot product of two int8 vectors in int32: the inner loop of the int8 CNN runtime.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::kernels {

// sum over i < n of a[i] * b[i], both signed 8-bit, any n and alignment. Exact while the true sum
// fits in int32, which is guaranteed for n <= 131071 (|a*b| <= 2^14); beyond that the result is the
// true sum modulo 2^32, identically in every variant. Dispatched to the best variant for this CPU
// (platform/cpu_features, EF_ISA caps it).
int32_t dot_i8(const int8_t* a, const int8_t* b, std::size_t n);

}  // namespace ef::kernels
