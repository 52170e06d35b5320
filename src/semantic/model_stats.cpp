#include "semantic/model_stats.h"

namespace ef::semantic {

ModelStats compute_model_stats(const nn::ModelDesc& desc) {
  using nn::LayerType;
  ModelStats s;
  s.layers.resize(desc.layers.size());
  for (std::size_t i = 0; i < desc.layers.size(); ++i) {
    const nn::LayerDesc& l = desc.layers[i];
    const bool conv = l.type == LayerType::kConv2d || l.type == LayerType::kDepthwiseConv2d ||
                      l.type == LayerType::kPointwiseConv2d;
    if (!conv || l.inputs.empty() || l.inputs[0] >= desc.tensors.size() || l.output >= desc.tensors.size()) continue;
    const nn::TensorDesc& in = desc.tensors[l.inputs[0]];
    const nn::TensorDesc& out = desc.tensors[l.output];
    const bool pointwise = l.type == LayerType::kPointwiseConv2d;
    const uint64_t kh = pointwise ? 1 : l.kernel_h, kw = pointwise ? 1 : l.kernel_w;
    const uint64_t cin_per_group = l.type == LayerType::kDepthwiseConv2d ? 1 : in.c;
    LayerStats& ls = s.layers[i];
    ls.macs = uint64_t{out.h} * out.w * out.c * kh * kw * cin_per_group;
    ls.parameters = uint64_t{out.c} * kh * kw * cin_per_group + out.c;
    s.macs += ls.macs;
    s.parameters += ls.parameters;
    s.weight_bytes += l.weights.size() + 4 * l.bias.size() + 4 * l.weight_scales.size();
    ++s.conv_layers;
  }
  return s;
}

std::string kernel_isa_summary(const nn::Executor& executor, std::size_t layer_count) {
  std::string out;
  for (std::size_t i = 0; i < layer_count; ++i) {
    const std::string name = executor.kernel_name(i);
    const auto sep = name.rfind("__");
    // Variant names are "<family>__<isa>" or "<family>_ref" (kernels/variants.h).
    const std::string isa = sep == std::string::npos ? "scalar" : name.substr(sep + 2);
    if (name.empty()) continue;
    if ((", " + out + ", ").find(", " + isa + ", ") == std::string::npos) out += (out.empty() ? "" : ", ") + isa;
  }
  return out.empty() ? "scalar" : out;
}

}  // namespace ef::semantic
