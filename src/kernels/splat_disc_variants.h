// Every variant of splat_disc (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::splat_disc (kernels/splat_disc.h).
// Files of this family are compiled with floating-point contraction off (src/CMakeLists.txt for
// ef_kernels, and kernels/fp_contract_off.h in each file), so products and sums round separately everywhere.
#pragma once

#include <cstdint>

#include "kernels/splat_disc.h"
#include "kernels/variants.h"

namespace ef::kernels {

using SplatDiscFn = void (*)(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner,
                             int width);

#define EF_KERNEL_VARIANT(fn, isa) \
  void fn(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner, int width);
#include "kernels/splat_disc.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<SplatDiscFn> kSplatDiscVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/splat_disc.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant splat_disc() dispatches to on this CPU.
const char* splat_disc_selected();

}  // namespace ef::kernels
