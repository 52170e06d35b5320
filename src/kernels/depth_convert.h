// Raw 16-bit depth to metres: dst[i] = src[i] * metres_per_unit, or 0 (invalid) when src[i] == 0
// or src[i] > max_valid_raw. Used by every dataset reader (TUM: 1/5000 m per unit, max 65535;
// 7-Scenes: 1/1000 m per unit, 65535 means invalid so max 65534).
// All variants give identical floats (one IEEE multiply per pixel, no FMA).
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::kernels {

// Dispatched to the best variant for this CPU (platform/cpu_features, EF_ISA caps it).
void depth_u16_to_metres(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                         uint16_t max_valid_raw);

}  // namespace ef::kernels
