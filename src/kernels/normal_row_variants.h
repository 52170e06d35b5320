// Every variant of normal_row (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::normal_row (kernels/normal_row.h).
// Files of this family are compiled with floating-point contraction off (src/CMakeLists.txt for
// ef_kernels, and kernels/fp_contract_off.h in each file), so products and sums round separately everywhere.
#pragma once

#include "kernels/normal_row.h"
#include "kernels/variants.h"

namespace ef::kernels {

using NormalRowFn = void (*)(const NormalRow& r, int x_begin, int x_end, float* normal);

#define EF_KERNEL_VARIANT(fn, isa) void fn(const NormalRow& r, int x_begin, int x_end, float* normal);
#include "kernels/normal_row.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<NormalRowFn> kNormalRowVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/normal_row.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant normal_row() dispatches to on this CPU.
const char* normal_row_selected();

}  // namespace ef::kernels
