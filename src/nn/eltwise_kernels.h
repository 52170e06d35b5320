// The kernel families of the int8 runtime other than convolutions, and their variant tables.
//
//   add_i8                out = requantised sum of two tensors (AddArgs, nn/layers_ref.h);
//                         vectorised over the flat element count; out may alias a or b.
//   maxpool_i8            NHWC max pool (PoolArgs); vectorised over channels; padding never wins.
//   avgpool_i8            NHWC average pool (PoolArgs); vectorised over channels: int32 window sums,
//                         float32 requantisation by window size (nn/avgpool_i8_simd.h).
//   clamp_i8              out = clamp(in) (ClampArgs); vectorised over the flat element count; out
//                         may alias in (nn/clamp_i8_simd.h).
//   concat_i8             channel concatenation (ConcatArgs); per input a copy or a requantisation,
//                         vectorised over its channels (nn/concat_i8_simd.h).
//   upsample_nearest_i8   integer-factor upsampling (UpsampleArgs), vectorised over channels
//   upsample_bilinear_i8  (nn/upsample_i8_simd.h; bilinear factors above 8 run the reference).
//   resize_bilinear_i8    bilinear resize to any size, TensorFlow align_corners (ResizeArgs), taps
//                         precomputed by the loader; vectorised over channels: int32 blends with
//                         11-bit weights (nn/resize_bilinear_i8_simd.h).
//   softmax_i8            int8 logits -> float32 probabilities (SoftmaxArgs); vectorised across
//                         pixels, 4 / 8 / 16 per vector, per-pixel float order kept
//                         (nn/softmax_i8_simd.h).
// Every variant gives the bytes (softmax: the float bits) of its reference (`<family>_ref`,
// nn/layers_ref.cpp) exactly. Tables follow kernels/variants.h: `<family>.inc` lists the variants
// lowest ISA first, row 0 the reference; the SIMD loops live in `<family>_simd.h` over the per-ISA
// block operations of nn/int8_simd.h (softmax: its own pixel vectors).
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

#define EF_KERNEL_VARIANT(fn, isa) void fn(const PoolArgs& a);
#include "nn/avgpool_i8.inc"
#undef EF_KERNEL_VARIANT

#define EF_KERNEL_VARIANT(fn, isa) void fn(const ClampArgs& a);
#include "nn/clamp_i8.inc"
#undef EF_KERNEL_VARIANT

#define EF_KERNEL_VARIANT(fn, isa) void fn(const ConcatArgs& a);
#include "nn/concat_i8.inc"
#undef EF_KERNEL_VARIANT

#define EF_KERNEL_VARIANT(fn, isa) void fn(const UpsampleArgs& a);
#include "nn/upsample_nearest_i8.inc"
#include "nn/upsample_bilinear_i8.inc"
#undef EF_KERNEL_VARIANT

#define EF_KERNEL_VARIANT(fn, isa) void fn(const ResizeArgs& a);
#include "nn/resize_bilinear_i8.inc"
#undef EF_KERNEL_VARIANT

#define EF_KERNEL_VARIANT(fn, isa) void fn(const SoftmaxArgs& a);
#include "nn/softmax_i8.inc"
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

inline constexpr kernels::KernelVariant<PoolI8Fn> kAvgPoolI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/avgpool_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<ClampI8Fn> kClampI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/clamp_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<ConcatI8Fn> kConcatI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/concat_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<UpsampleI8Fn> kUpsampleNearestI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/upsample_nearest_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<UpsampleI8Fn> kUpsampleBilinearI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/upsample_bilinear_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<ResizeI8Fn> kResizeBilinearI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/resize_bilinear_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<SoftmaxI8Fn> kSoftmaxI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/softmax_i8.inc"
#undef EF_KERNEL_VARIANT
};

// Elements [begin, end) of a flat add by the reference: the SIMD variants' tail. Compiled for the
// baseline ISA.
void add_i8_ref_range(const AddArgs& a, std::size_t begin, std::size_t end);

// The variants the executor may use on this CPU (detection capped by EF_ISA, platform/cpu_features.h).
const kernels::KernelVariant<AddI8Fn>& add_i8_selected();
const kernels::KernelVariant<PoolI8Fn>& maxpool_i8_selected();
const kernels::KernelVariant<PoolI8Fn>& avgpool_i8_selected();
const kernels::KernelVariant<ClampI8Fn>& clamp_i8_selected();
const kernels::KernelVariant<ConcatI8Fn>& concat_i8_selected();
const kernels::KernelVariant<UpsampleI8Fn>& upsample_nearest_i8_selected();
const kernels::KernelVariant<UpsampleI8Fn>& upsample_bilinear_i8_selected();
const kernels::KernelVariant<ResizeI8Fn>& resize_bilinear_i8_selected();
const kernels::KernelVariant<SoftmaxI8Fn>& softmax_i8_selected();

}  // namespace ef::nn
