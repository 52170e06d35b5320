// Every variant of pyramid_row (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::pyramid_row (kernels/pyramid_row.h).
// Files of this family are compiled with floating-point contraction off (src/CMakeLists.txt for
// ef_kernels, and kernels/fp_contract_off.h in each file), so products and sums round separately everywhere.
#pragma once

#include "kernels/pyramid_row.h"
#include "kernels/variants.h"

namespace ef::kernels {

using PyramidRowFn = void (*)(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out);

#define EF_KERNEL_VARIANT(fn, isa) \
  void fn(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out);
#include "kernels/pyramid_row.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<PyramidRowFn> kPyramidRowVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/pyramid_row.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant pyramid_row() dispatches to on this CPU.
const char* pyramid_row_selected();

}  // namespace ef::kernels
