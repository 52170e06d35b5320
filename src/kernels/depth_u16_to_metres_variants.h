// Every variant of depth_u16_to_metres (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::depth_u16_to_metres (kernels/depth_convert.h).
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/variants.h"

namespace ef::kernels {

using DepthU16ToMetresFn = void (*)(const uint16_t* src, float* dst, std::size_t n,
                                    float metres_per_unit, uint16_t max_valid_raw);

#define EF_KERNEL_VARIANT(fn, isa) \
  void fn(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit, uint16_t max_valid_raw);
#include "kernels/depth_u16_to_metres.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<DepthU16ToMetresFn> kDepthU16ToMetresVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/depth_u16_to_metres.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant depth_u16_to_metres() dispatches to on this CPU.
const char* depth_u16_to_metres_selected();

}  // namespace ef::kernels
