// Every variant of dot_i8 (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::dot_i8 (kernels/dot_i8.h).
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/variants.h"

namespace ef::kernels {

using DotI8Fn = int32_t (*)(const int8_t* a, const int8_t* b, std::size_t n);

#define EF_KERNEL_VARIANT(fn, isa) int32_t fn(const int8_t* a, const int8_t* b, std::size_t n);
#include "kernels/dot_i8.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<DotI8Fn> kDotI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/dot_i8.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant dot_i8() dispatches to on this CPU.
const char* dot_i8_selected();

// Adds int32 partial sums with wrap-around (mod 2^32), as the SIMD lanes do, without the undefined
// behaviour of signed overflow. `static` (internal linkage) because ISA files call it: see the rule
// in kernels/variants.h.
static inline int32_t wrapping_add_i32(int32_t x, int32_t y) {
  return static_cast<int32_t>(static_cast<uint32_t>(x) + static_cast<uint32_t>(y));
}

}  // namespace ef::kernels
