// Every variant of gradient_fill_row (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::gradient_fill_row (kernels/gradient_fill_row.h).
// Files of this family are compiled with floating-point contraction off (src/CMakeLists.txt for
// ef_kernels, and kernels/fp_contract_off.h in each file), so products and sums round separately everywhere.
#pragma once

#include "kernels/gradient_fill_row.h"
#include "kernels/variants.h"

namespace ef::kernels {

using GradientFillRowFn = void (*)(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                                   float* filled);

#define EF_KERNEL_VARIANT(fn, isa) \
  void fn(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y, float* filled);
#include "kernels/gradient_fill_row.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<GradientFillRowFn> kGradientFillRowVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/gradient_fill_row.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant gradient_fill_row() dispatches to on this CPU.
const char* gradient_fill_row_selected();

}  // namespace ef::kernels
