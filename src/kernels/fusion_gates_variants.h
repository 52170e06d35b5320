// Every variant of fusion_gates (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::fusion_gates (kernels/fusion_gates.h).
// Files of this family are compiled with floating-point contraction off (src/CMakeLists.txt for
// ef_kernels, and kernels/fp_contract_off.h in each file), so products and sums round separately everywhere.
#pragma once

#include <cstdint>

#include "kernels/fusion_gates.h"
#include "kernels/variants.h"

namespace ef::kernels {

using FusionGatesFn = void (*)(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end,
                               uint32_t* code);

#define EF_KERNEL_VARIANT(fn, isa) \
  void fn(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code);
#include "kernels/fusion_gates.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<FusionGatesFn> kFusionGatesVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/fusion_gates.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant fusion_gates() dispatches to on this CPU.
const char* fusion_gates_selected();

}  // namespace ef::kernels
