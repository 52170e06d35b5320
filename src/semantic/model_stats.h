// Size and cost figures of a network, from its description alone (no executor needed): what
// `edgefusion model info` and bench_nn_model print.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "nn/executor.h"
#include "nn/model_format.h"

namespace ef::semantic {

struct LayerStats {
  uint64_t macs = 0;        // multiply-accumulates of one forward pass (convolutions; 0 otherwise)
  uint64_t parameters = 0;  // int8 weights + int32 biases (convolutions; 0 otherwise)
};

struct ModelStats {
  uint64_t macs = 0;          // sum over convolution layers of out_h * out_w * cout * kh * kw * cin_per_group
                              // (padding taps counted, as XNNPACK and bench_nn_conv count them)
  uint64_t parameters = 0;    // weights + biases of every convolution (the per-channel scales not counted)
  uint64_t weight_bytes = 0;  // int8 weights + int32 biases + float32 weight scales as stored in the file
  int conv_layers = 0;        // conv2d, depthwise and pointwise layers
  std::vector<LayerStats> layers;  // one per layer, in file order
};

// cin_per_group is Cin for conv2d and pointwise layers and 1 for depthwise ones; a pointwise layer
// counts as 1 x 1 whatever its unused kernel fields say.
ModelStats compute_model_stats(const nn::ModelDesc& desc);

// The ISA levels of the kernel variants an executor picked, distinct, in layer order: "avx2",
// "avx512vnni", or "avx2, sse41" when families differ; "scalar" when every layer runs its scalar
// reference. Layers that only have a reference (concat, clamp, avg pool, upsample, softmax) do not
// count.
std::string kernel_isa_summary(const nn::Executor& executor, std::size_t layer_count);

}  // namespace ef::semantic
