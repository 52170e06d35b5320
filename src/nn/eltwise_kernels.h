// Element-wise and pooling kernel families of the int8 runtime and their variant tables.
//
//   add_i8      out = requantised sum of two tensors (AddArgs, nn/layers_ref.h); vectorised over
//               the flat element count; out may alias a or b.
//   maxpool_i8  NHWC max pool (PoolArgs); vectorised over channels; padding never wins.
// Every variant gives the bytes of its reference (add_i8_ref / maxpool_i8_ref) exactly. Tables
// follow kernels/variants.h: `<family>.inc` lists the variants lowest ISA first, row 0 the reference.
#pragma once

#include <cstddef>

#include "kernels/variants.h"
#include "nn/layers_ref.h"

namespace ef::nn {

#define EF_KERNEL_VARIANT(fn, isa) void fn(const AddArgs& a);
#include "nn/add_i8.inc"
#undef EF_KERNEL_VARIANT

#define EF_KERNEL_VARIANT(fn, isa) void fn(const PoolArgs& a);
#include "nn/maxpool_i8.inc"
#undef EF_KERNEL_VARIANT

inline constexpr kernels::KernelVariant<AddI8Fn> kAddI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/add_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<PoolI8Fn> kMaxPoolI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/maxpool_i8.inc"
#undef EF_KERNEL_VARIANT
};

// The variants the executor may use on this CPU (detection capped by EF_ISA, platform/cpu_features.h).
// Elements [begin, end) of a flat add by the reference: the SIMD variants' tail. Compiled for the
// baseline ISA.
void add_i8_ref_range(const AddArgs& a, std::size_t begin, std::size_t end);

const kernels::KernelVariant<AddI8Fn>& add_i8_selected();
const kernels::KernelVariant<PoolI8Fn>& maxpool_i8_selected();

}  // namespace ef::nn
