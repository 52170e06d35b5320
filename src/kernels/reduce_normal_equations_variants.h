// Every variant of reduce_normal_equations (internal: the dispatcher, tests and benchmark use it),
// and the pieces of the summation order that all variants share.
// Contract of each variant: that of ef::kernels::reduce_normal_equations (kernels/normal_equations.h).
//
// Files of this family are compiled with floating-point contraction off (kernels/fp_contract_off.h,
// because the compiler's C++ default contracts a*b+c into FMA when the ISA has it: AArch64 always,
// x86 with -mfma), so that products and sums round separately everywhere.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/normal_equations.h"
#include "kernels/variants.h"

namespace ef::kernels {

using ReduceNormalEquationsFn = void (*)(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out);

#define EF_KERNEL_VARIANT(fn, isa) void fn(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out);
#include "kernels/reduce_normal_equations.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<ReduceNormalEquationsFn> kReduceNormalEquationsVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/reduce_normal_equations.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant reduce_normal_equations() dispatches to on this CPU.
const char* reduce_normal_equations_selected();

// Shared steps, compiled for the baseline (normal_equations.cpp) and called by every variant:

// Double lane totals: totals[o * kNeLanes + l] for output o, lane l.
using NeLaneTotals = double[kNeOutputs * kNeLanes];

// Copies rows [begin, begin + count) (count < kNeLanes) into an 8-row tile with stride kNeLanes,
// padding the missing rows with zeros; padded rows add (0 * 0) * 0 = +0 to a lane sum, which leaves
// it unchanged (a lane sum is never -0: it starts at +0 and x + (-x) rounds to +0).
void ne_tail_tile(const float* rows, std::size_t stride, std::size_t begin, std::size_t count,
                  float tile[kNeComponents * kNeLanes]);

// Rows with w > 0 among rows [0, n).
int64_t ne_count_inliers(const float* w, std::size_t n);

// Combines the lanes of each output in the fixed tree ((l0 + l1) + (l2 + l3)) + ((l4 + l5) + (l6 + l7)).
void ne_finish(const NeLaneTotals& totals, int64_t inliers, NormalEquations* out);

}  // namespace ef::kernels
