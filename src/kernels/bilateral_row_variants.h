// Every variant of bilateral_row (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::bilateral_row (kernels/bilateral_row.h).
// Files of this family are compiled with floating-point contraction off (src/CMakeLists.txt for
// ef_kernels, and kernels/fp_contract_off.h in each file), so products and sums round separately everywhere.
#pragma once

#include "kernels/bilateral_row.h"
#include "kernels/variants.h"

namespace ef::kernels {

using BilateralRowFn = void (*)(const BilateralRow& b, int width, float* out);

#define EF_KERNEL_VARIANT(fn, isa) void fn(const BilateralRow& b, int width, float* out);
#include "kernels/bilateral_row.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<BilateralRowFn> kBilateralRowVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/bilateral_row.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant bilateral_row() dispatches to on this CPU.
const char* bilateral_row_selected();

}  // namespace ef::kernels
