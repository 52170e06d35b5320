// Convolution kernel families of the int8 runtime and their variant tables.
//
// Two families:
//   conv_i8    k x k convolutions (conv2d) and 1x1 pointwise convolutions: an implicit GEMM over
//              output pixels x output channels with K = kh * kw * Cin.
//   dwconv_i8  depthwise convolutions (one filter per channel).
// A variant packs the file-layout weights once at load into whatever layout it wants (pack), and
// then computes output rows [a.oy_begin, a.oy_end) from those bytes (run). Every variant gives the
// bytes of the scalar reference (conv2d_i8_ref / dwconv2d_i8_ref in nn/layers_ref.h) exactly:
// the requantisation is nn/requantize.h, shared by all.
//
// Tables follow kernels/variants.h: `<family>.inc` lists the variants lowest ISA first, the executor
// takes the best one the CPU runs, tests run every runnable one against the reference, and the
// benchmark (bench/nn_conv.cpp) times each.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/variants.h"
#include "nn/layers_ref.h"

namespace ef::nn {

// What packing needs to know about a layer. For conv_i8 a pointwise layer is kernel 1 x 1.
struct ConvShape {
  int in_c = 1, out_c = 1;         // channels; depthwise: in_c == out_c
  int kernel_h = 1, kernel_w = 1;  // taps
  int32_t in_zero_point = 0;       // the input tensor's zero point (a pack may fold it into biases)
};

// The layer's parameters in the file layout (docs/model_format.md): conv weights
// [out_c][kh][kw][in_c], depthwise [c][kh][kw]; bias and requant per output channel.
struct ConvParams {
  const int8_t* weights = nullptr;
  const int32_t* bias = nullptr;
  const Requant* requant = nullptr;
};

// One variant. Functions, not virtual calls: a table row is plain data.
struct ConvKernel {
  // Bytes pack() writes for this shape (0: the variant reads ConvArgs::weights directly).
  std::size_t (*packed_bytes)(const ConvShape& shape);
  // Writes the packed form to `dst` (packed_bytes(shape) bytes, 64-byte aligned). Never fails.
  void (*pack)(const ConvShape& shape, const ConvParams& params, void* dst);
  // Computes output rows [a.oy_begin, a.oy_end) (oy_end < 0: all). a.packed is what pack() wrote
  // for this layer; a.weights / a.bias / a.requant are the file-layout arrays. No allocation.
  void (*run)(const ConvArgs& a);
};

using ConvKernelPtr = const ConvKernel*;

#define EF_KERNEL_VARIANT(fn, isa) extern const ConvKernel fn;
#include "nn/conv_i8.inc"
#include "nn/dwconv_i8.inc"
#undef EF_KERNEL_VARIANT

inline constexpr kernels::KernelVariant<ConvKernelPtr> kConvI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/conv_i8.inc"
#undef EF_KERNEL_VARIANT
};

inline constexpr kernels::KernelVariant<ConvKernelPtr> kDwConvI8Variants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, kernels::Isa::isa, &fn},
#include "nn/dwconv_i8.inc"
#undef EF_KERNEL_VARIANT
};

// The variants the executor uses on this CPU (detection capped by EF_ISA, platform/cpu_features.h).
const kernels::KernelVariant<ConvKernelPtr>& conv_i8_selected();
const kernels::KernelVariant<ConvKernelPtr>& dwconv_i8_selected();

}  // namespace ef::nn
