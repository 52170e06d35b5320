// .efm writer, reader and validator (versions 1 and 2). The byte layout is specified in docs/model_format.md; the
// reader trusts nothing: every count, index, offset and size is checked before it is used.
#include "nn/model_format.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string_view>

namespace ef::nn {

const char* layer_type_name(LayerType t) {
  switch (t) {
    case LayerType::kConv2d: return "conv2d";
    case LayerType::kDepthwiseConv2d: return "depthwise_conv2d";
    case LayerType::kPointwiseConv2d: return "pointwise_conv2d";
    case LayerType::kAdd: return "add";
    case LayerType::kConcat: return "concat";
    case LayerType::kClamp: return "clamp";
    case LayerType::kMaxPool: return "max_pool";
    case LayerType::kAvgPool: return "avg_pool";
    case LayerType::kUpsample: return "upsample";
    case LayerType::kSoftmax: return "softmax";
    case LayerType::kResizeBilinear: return "resize_bilinear";
  }
  return "unknown";
}

uint32_t crc32(const void* data, std::size_t size) {
  // Reflected polynomial 0xEDB88320, initial value and final XOR 0xFFFFFFFF (zlib). The 256-entry
  // table is built once (thread-safe static initialisation).
  static const auto table = [] {
    struct T { uint32_t v[256]; } t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t.v[i] = c;
    }
    return t;
  }();
  const auto* p = static_cast<const unsigned char*>(data);
  uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) crc = table.v[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

namespace {

constexpr uint32_t fourcc(const char (&s)[5]) {
  return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
         uint32_t(uint8_t(s[3])) << 24;
}
constexpr uint32_t kTagMeta = fourcc("META");
constexpr uint32_t kTagTens = fourcc("TENS");
constexpr uint32_t kTagLayr = fourcc("LAYR");
constexpr uint32_t kTagWght = fourcc("WGHT");
constexpr uint32_t kTagCmap = fourcc("CMAP");

// ---------------------------------------------------------------------------------------------
// Messages: "<file>: <section>: <what>".
Error fault(const std::string& file, const char* section, const std::string& what) {
  return error(ErrorCode::kCorruptData, file + ": " + section + ": " + what);
}
std::string layer_prefix(std::size_t i, LayerType t) {
  return "layer " + std::to_string(i) + " (" + layer_type_name(t) + "): ";
}
std::string shape_str(const TensorDesc& t) {
  return std::to_string(t.n) + "x" + std::to_string(t.h) + "x" + std::to_string(t.w) + "x" + std::to_string(t.c);
}
bool positive_finite(float v) { return std::isfinite(v) && v > 0.0f; }

// ---------------------------------------------------------------------------------------------
// Little-endian writer.
class Writer {
 public:
  void u8(uint8_t v) { s_.push_back(static_cast<char>(v)); }
  void u16(uint16_t v) { for (int i = 0; i < 2; ++i) u8(uint8_t(v >> (8 * i))); }
  void u32(uint32_t v) { for (int i = 0; i < 4; ++i) u8(uint8_t(v >> (8 * i))); }
  void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
  void f32(float v) { uint32_t b; std::memcpy(&b, &v, 4); u32(b); }
  void bytes(const void* p, std::size_t n) { s_.append(static_cast<const char*>(p), n); }
  void pad4() { while (s_.size() % 4) u8(0); }
  std::string& str() { return s_; }
 private:
  std::string s_;
};

// Little-endian bounds-checked reader over one section body.
class Reader {
 public:
  Reader(const unsigned char* p, std::size_t n) : p_(p), n_(n) {}
  bool u8(uint8_t& v) { if (!need(1)) return false; v = p_[pos_++]; return true; }
  bool u16(uint16_t& v) {
    if (!need(2)) return false;
    v = uint16_t(p_[pos_] | p_[pos_ + 1] << 8);
    pos_ += 2;
    return true;
  }
  bool u32(uint32_t& v) {
    if (!need(4)) return false;
    v = uint32_t(p_[pos_]) | uint32_t(p_[pos_ + 1]) << 8 | uint32_t(p_[pos_ + 2]) << 16 | uint32_t(p_[pos_ + 3]) << 24;
    pos_ += 4;
    return true;
  }
  bool i32(int32_t& v) { uint32_t u; if (!u32(u)) return false; v = static_cast<int32_t>(u); return true; }
  bool f32(float& v) { uint32_t u; if (!u32(u)) return false; std::memcpy(&v, &u, 4); return true; }
  bool bytes(void* dst, std::size_t n) {
    if (!need(n)) return false;
    std::memcpy(dst, p_ + pos_, n);
    pos_ += n;
    return true;
  }
  std::size_t pos() const { return pos_; }
  std::size_t left() const { return n_ - pos_; }
  const unsigned char* data() const { return p_; }
 private:
  bool need(std::size_t k) const { return k <= n_ - pos_; }
  const unsigned char* p_;
  std::size_t n_;
  std::size_t pos_ = 0;
};

bool has_weights(LayerType t) {
  return t == LayerType::kConv2d || t == LayerType::kDepthwiseConv2d || t == LayerType::kPointwiseConv2d;
}

// Weights per output channel (K) for a convolution with input channels cin.
uint64_t weights_per_channel(const LayerDesc& l, uint32_t cin) {
  switch (l.type) {
    case LayerType::kConv2d: return uint64_t{l.kernel_h} * l.kernel_w * cin;
    case LayerType::kDepthwiseConv2d: return uint64_t{l.kernel_h} * l.kernel_w;
    case LayerType::kPointwiseConv2d: return cin;
    default: return 0;
  }
}

// Output size of a windowed op along one axis; 0 when the window does not fit.
uint64_t window_out(uint32_t in, uint32_t k, uint32_t stride, uint32_t dil, uint32_t pad_a, uint32_t pad_b) {
  const uint64_t span = uint64_t{dil} * (k - 1) + 1;
  const uint64_t padded = uint64_t{in} + pad_a + pad_b;
  if (padded < span) return 0;
  return (padded - span) / stride + 1;
}

// Weight repacking hook: the layout each kernel wants, computed once at load. The scalar reference
// reads the file layout, so for now this is a copy; SIMD kernels will add their packings here.
std::vector<int8_t> repack_weights(const LayerDesc& l, uint32_t cin) {
  (void)cin;
  return l.weights;
}

// ---------------------------------------------------------------------------------------------
// Validation of one layer: arity, shapes, parameters, weights; fills `prep`.
Status check_layer(const ModelDesc& d, std::size_t li, const std::string& file, PreparedLayer& prep) {
  const LayerDesc& l = d.layers[li];
  const std::string where = layer_prefix(li, l.type);
  auto bad = [&](const std::string& what) { return fault(file, "LAYR", where + what); };
  const TensorDesc& out = d.tensors[l.output];
  const TensorDesc& in0 = d.tensors[l.inputs[0]];
  const auto same_quant = [&](const TensorDesc& a, const TensorDesc& b) {
    return a.scale == b.scale && a.zero_point == b.zero_point;
  };
  const auto check_range = [&]() -> Status {
    if (l.out_min < -128 || l.out_max > 127 || l.out_min > l.out_max)
      return bad("output range [" + std::to_string(l.out_min) + ", " + std::to_string(l.out_max) +
                 "] is not an ordered sub-range of [-128, 127]");
    return {};
  };
  const auto check_window = [&](bool conv) -> Status {
    // A global average pool may exceed kMaxKernel (up to kMaxGlobalPool: its sums stay in int32).
    const bool global = is_global_pool(l, in0);
    const uint32_t max_k = global ? kMaxGlobalPool : kMaxKernel;
    if (l.kernel_h < 1 || l.kernel_w < 1 || l.kernel_h > max_k || l.kernel_w > max_k)
      return bad("kernel " + std::to_string(l.kernel_h) + "x" + std::to_string(l.kernel_w) + " outside 1.." +
                 std::to_string(max_k) +
                 (global ? " (global average pool)"
                         : l.type == LayerType::kAvgPool
                               ? " (up to " + std::to_string(kMaxGlobalPool) + " only for a global average pool: window = "
                                     "input H x W, stride 1, no padding)"
                               : ""));
    if (l.stride_h < 1 || l.stride_w < 1 || l.stride_h > kMaxStride || l.stride_w > kMaxStride)
      return bad("stride outside 1.." + std::to_string(kMaxStride));
    const uint32_t dh = conv ? l.dilation_h : 1, dw = conv ? l.dilation_w : 1;
    if (dh < 1 || dw < 1 || dh > kMaxDilation || dw > kMaxDilation)
      return bad("dilation outside 1.." + std::to_string(kMaxDilation));
    if (l.pad_top > kMaxPad || l.pad_left > kMaxPad || l.pad_bottom > kMaxPad || l.pad_right > kMaxPad)
      return bad("padding above " + std::to_string(kMaxPad));
    // Pools: padding smaller than the window, so every window holds at least one input position.
    if (!conv && (l.pad_top >= l.kernel_h || l.pad_bottom >= l.kernel_h || l.pad_left >= l.kernel_w ||
                  l.pad_right >= l.kernel_w))
      return bad("pool padding must be smaller than the window");
    const uint64_t oh = window_out(in0.h, l.kernel_h, l.stride_h, dh, l.pad_top, l.pad_bottom);
    const uint64_t ow = window_out(in0.w, l.kernel_w, l.stride_w, dw, l.pad_left, l.pad_right);
    if (oh == 0 || ow == 0) return bad("window larger than the padded input " + shape_str(in0));
    if (out.h != oh || out.w != ow)
      return bad("output shape " + shape_str(out) + " but input " + shape_str(in0) + " gives " +
                 std::to_string(oh) + "x" + std::to_string(ow) + " spatially");
    return {};
  };

  // Arity and dtypes.
  std::size_t min_in = 1, max_in = 1;
  if (l.type == LayerType::kAdd) min_in = max_in = 2;
  if (l.type == LayerType::kConcat) max_in = kMaxLayerInputs;
  if (l.inputs.size() < min_in || l.inputs.size() > max_in)
    return bad(std::to_string(l.inputs.size()) + " inputs, needs " + std::to_string(min_in) +
               (min_in == max_in ? "" : ".." + std::to_string(max_in)));
  for (uint32_t t : l.inputs)
    if (d.tensors[t].dtype != DType::kInt8) return bad("input tensor " + std::to_string(t) + " is not int8");
  if (l.type == LayerType::kSoftmax) {
    if (out.dtype != DType::kFloat32) return bad("softmax output must be float32");
    if (l.output != d.output_tensor) return bad("softmax must produce the model output tensor");
  } else if (out.dtype != DType::kInt8) {
    return bad("output tensor " + std::to_string(l.output) + " is not int8");
  }
  if (!has_weights(l.type) && (!l.bias.empty() || !l.weights.empty() || !l.weight_scales.empty())) {
    return bad("has weights but the layer type takes none");
  }

  switch (l.type) {
    case LayerType::kConv2d:
    case LayerType::kDepthwiseConv2d:
    case LayerType::kPointwiseConv2d: {
      if (l.type == LayerType::kPointwiseConv2d) {
        if (l.kernel_h != 1 || l.kernel_w != 1 || l.stride_h != 1 || l.stride_w != 1 || l.pad_top || l.pad_left ||
            l.pad_bottom || l.pad_right)
          return bad("pointwise convolution must be 1x1, stride 1, no padding");
      }
      EF_RETURN_IF_ERROR(check_window(true));
      EF_RETURN_IF_ERROR(check_range());
      if (l.type == LayerType::kDepthwiseConv2d && out.c != in0.c)
        return bad("depthwise output channels " + std::to_string(out.c) + " != input channels " + std::to_string(in0.c));
      const uint64_t k = weights_per_channel(l, in0.c);
      if (k > kMaxReduction) return bad("reduction of " + std::to_string(k) + " terms per output exceeds " + std::to_string(kMaxReduction));
      if (l.weight_scales.size() != out.c || l.bias.size() != out.c)
        return bad("needs " + std::to_string(out.c) + " weight scales and biases, has " +
                   std::to_string(l.weight_scales.size()) + " and " + std::to_string(l.bias.size()));
      if (l.weights.size() != k * out.c)
        return bad("needs " + std::to_string(k * out.c) + " weights, has " + std::to_string(l.weights.size()));
      for (std::size_t i = 0; i < l.weights.size(); ++i)
        if (l.weights[i] == -128) return bad("weight " + std::to_string(i) + " is -128 (symmetric weights are in [-127, 127])");
      prep.requant.resize(out.c);
      for (uint32_t c = 0; c < out.c; ++c) {
        if (!positive_finite(l.weight_scales[c])) return bad("weight scale of channel " + std::to_string(c) + " is not finite and positive");
        if (l.bias[c] > kMaxAbsBias || l.bias[c] < -kMaxAbsBias) return bad("bias of channel " + std::to_string(c) + " beyond +-2^30");
        const double m = double(in0.scale) * double(l.weight_scales[c]) / double(out.scale);
        if (!make_multiplier(m, &prep.requant[c].multiplier))
          return bad("requantisation multiplier of channel " + std::to_string(c) + " (" + std::to_string(m) +
                     ") is not a normal float32 below 2^24");
      }
      prep.packed = repack_weights(l, in0.c);
      prep.bias = l.bias;
      break;
    }
    case LayerType::kAdd: {
      const TensorDesc& in1 = d.tensors[l.inputs[1]];
      if (in0.h != in1.h || in0.w != in1.w || in0.c != in1.c || out.h != in0.h || out.w != in0.w || out.c != in0.c)
        return bad("shapes differ: " + shape_str(in0) + " + " + shape_str(in1) + " -> " + shape_str(out));
      EF_RETURN_IF_ERROR(check_range());
      const double m[2] = {double(in0.scale) / double(out.scale), double(in1.scale) / double(out.scale)};
      prep.requant.resize(2);
      for (int i = 0; i < 2; ++i)
        if (!make_multiplier(m[i], &prep.requant[i].multiplier))
          return bad("input " + std::to_string(i) + "/output scale ratio (" + std::to_string(m[i]) +
                     ") is not a normal float32 below 2^24");
      break;
    }
    case LayerType::kConcat: {
      uint64_t channels = 0;
      for (std::size_t i = 0; i < l.inputs.size(); ++i) {
        const TensorDesc& t = d.tensors[l.inputs[i]];
        if (t.h != out.h || t.w != out.w) return bad("input " + std::to_string(i) + " shape " + shape_str(t) + " differs spatially from output " + shape_str(out));
        channels += t.c;
        const double m = double(t.scale) / double(out.scale);
        Requant rq;
        if (!make_multiplier(m, &rq.multiplier))
          return bad("input " + std::to_string(i) + " to output scale ratio (" + std::to_string(m) +
                     ") is not a normal float32 below 2^24");
        prep.requant.push_back(rq);
      }
      if (channels != out.c) return bad("input channels sum to " + std::to_string(channels) + ", output has " + std::to_string(out.c));
      break;
    }
    case LayerType::kClamp:
      if (in0.h != out.h || in0.w != out.w || in0.c != out.c) return bad("shape " + shape_str(in0) + " -> " + shape_str(out));
      if (!same_quant(in0, out)) return bad("input and output quantisation must match");
      EF_RETURN_IF_ERROR(check_range());
      break;
    case LayerType::kMaxPool:
    case LayerType::kAvgPool: {
      EF_RETURN_IF_ERROR(check_window(false));
      if (out.c != in0.c) return bad("pool changes channels " + std::to_string(in0.c) + " -> " + std::to_string(out.c));
      if (l.type == LayerType::kMaxPool) {
        if (!same_quant(in0, out)) return bad("input and output quantisation must match");
      } else {
        // One multiplier per window count that can occur: 1..kh*kw, or kh*kw alone for a global pool
        // (PoolArgs::requant_count_base).
        const uint32_t window = l.kernel_h * l.kernel_w;
        const uint32_t first = is_global_pool(l, in0) ? window : 1;
        prep.requant.resize(window - first + 1);
        for (uint32_t k = first; k <= window; ++k) {
          const double m = double(in0.scale) / double(out.scale) / double(k);
          if (!make_multiplier(m, &prep.requant[k - first].multiplier))
            return bad("input/output scale ratio over a window of " + std::to_string(k) + " (" + std::to_string(m) +
                       ") is not a normal float32 below 2^24");
        }
      }
      break;
    }
    case LayerType::kUpsample:
      if (l.factor < 1 || l.factor > kMaxUpsample) return bad("factor " + std::to_string(l.factor) + " outside 1.." + std::to_string(kMaxUpsample));
      if (l.mode != UpsampleMode::kNearest && l.mode != UpsampleMode::kBilinear) return bad("unknown upsampling mode");
      if (uint64_t{in0.h} * l.factor != out.h || uint64_t{in0.w} * l.factor != out.w || in0.c != out.c)
        return bad("output " + shape_str(out) + " is not input " + shape_str(in0) + " times " + std::to_string(l.factor));
      if (!same_quant(in0, out)) return bad("input and output quantisation must match");
      break;
    case LayerType::kResizeBilinear:
      // Any output size (the tensor checks keep H and W in 1..kMaxDim); channels and quantisation kept.
      if (in0.c != out.c)
        return bad("changes channels " + std::to_string(in0.c) + " -> " + std::to_string(out.c) + " (" +
                   shape_str(in0) + " -> " + shape_str(out) + ")");
      if (!same_quant(in0, out))
        return bad("input and output quantisation must match (scale " + std::to_string(in0.scale) + " zero point " +
                   std::to_string(in0.zero_point) + " -> scale " + std::to_string(out.scale) + " zero point " +
                   std::to_string(out.zero_point) + ")");
      prep.resize_taps.resize(std::size_t(out.h) + out.w);
      for (uint32_t o = 0; o < out.h; ++o) prep.resize_taps[o] = resize_tap(int32_t(o), int32_t(in0.h), int32_t(out.h));
      for (uint32_t o = 0; o < out.w; ++o)
        prep.resize_taps[out.h + o] = resize_tap(int32_t(o), int32_t(in0.w), int32_t(out.w));
      break;
    case LayerType::kSoftmax:
      if (in0.h != out.h || in0.w != out.w || in0.c != out.c) return bad("shape " + shape_str(in0) + " -> " + shape_str(out));
      prep.exp_table.resize(256);
      for (int q = 0; q < 256; ++q) prep.exp_table[q] = static_cast<float>(std::exp(-double(in0.scale) * q));
      break;
  }
  return {};
}

// The optional class map (CMAP): both lists empty, or one target class per output channel, each
// below the number of target class names.
Status check_class_map(const ModelDesc& d, const std::string& file) {
  if (d.class_map.empty() && d.target_class_names.empty()) return {};
  if (d.class_map.empty() || d.target_class_names.empty())
    return fault(file, "CMAP", "a class map needs target class names and the reverse (" + std::to_string(d.class_map.size()) +
                                   " map entries, " + std::to_string(d.target_class_names.size()) + " target names)");
  if (d.target_class_names.size() > kMaxClasses)
    return fault(file, "CMAP", std::to_string(d.target_class_names.size()) + " target classes, allowed 1.." + std::to_string(kMaxClasses));
  for (std::size_t i = 0; i < d.target_class_names.size(); ++i)
    if (d.target_class_names[i].empty() || d.target_class_names[i].size() > kMaxClassNameBytes)
      return fault(file, "CMAP", "target class " + std::to_string(i) + " name empty or longer than " +
                                     std::to_string(kMaxClassNameBytes) + " bytes");
  const std::size_t outputs = d.tensors[d.output_tensor].c;
  if (d.class_map.size() != outputs)
    return fault(file, "CMAP", std::to_string(d.class_map.size()) + " map entries but the output has " + std::to_string(outputs) + " channels");
  for (std::size_t k = 0; k < d.class_map.size(); ++k)
    if (d.class_map[k] >= d.target_class_names.size())
      return fault(file, "CMAP", "output channel " + std::to_string(k) + " maps to class " + std::to_string(d.class_map[k]) +
                                     ", beyond the " + std::to_string(d.target_class_names.size()) + " target classes");
  return {};
}

}  // namespace

bool is_global_pool(const LayerDesc& l, const TensorDesc& in) {
  return l.type == LayerType::kAvgPool && l.kernel_h == in.h && l.kernel_w == in.w && l.stride_h == 1 &&
         l.stride_w == 1 && l.pad_top == 0 && l.pad_left == 0 && l.pad_bottom == 0 && l.pad_right == 0;
}

// -----------------------------------------------------------------------------------------------
Result<Model> prepare_model(ModelDesc d, const std::string& file) {
  if (d.name.size() > kMaxNameBytes) return fault(file, "META", "model name longer than " + std::to_string(kMaxNameBytes) + " bytes");
  // Tensors.
  if (d.tensors.empty() || d.tensors.size() > kMaxTensors)
    return fault(file, "TENS", std::to_string(d.tensors.size()) + " tensors, allowed 1.." + std::to_string(kMaxTensors));
  for (std::size_t i = 0; i < d.tensors.size(); ++i) {
    const TensorDesc& t = d.tensors[i];
    const std::string where = "tensor " + std::to_string(i) + ": ";
    if (t.dtype != DType::kInt8 && t.dtype != DType::kFloat32) return fault(file, "TENS", where + "unknown dtype");
    if (t.n != 1) return fault(file, "TENS", where + "batch " + std::to_string(t.n) + ", only 1 is supported");
    if (t.h < 1 || t.w < 1 || t.c < 1 || t.h > kMaxDim || t.w > kMaxDim || t.c > kMaxDim)
      return fault(file, "TENS", where + "shape " + shape_str(t) + " has a dimension outside 1.." + std::to_string(kMaxDim));
    if (t.elements() > kMaxTensorElements) return fault(file, "TENS", where + "shape " + shape_str(t) + " is too large");
    if (t.dtype == DType::kInt8) {
      if (!positive_finite(t.scale)) return fault(file, "TENS", where + "scale " + std::to_string(t.scale) + " is not finite and positive");
      if (t.zero_point < -128 || t.zero_point > 127) return fault(file, "TENS", where + "zero point " + std::to_string(t.zero_point) + " outside [-128, 127]");
    } else if (t.scale != 1.0f || t.zero_point != 0) {
      return fault(file, "TENS", where + "float32 tensor must have scale 1 and zero point 0");
    }
  }
  // Graph input and output, normalisation, classes.
  if (d.input_tensor >= d.tensors.size() || d.output_tensor >= d.tensors.size())
    return fault(file, "META", "input/output tensor id out of range (" + std::to_string(d.tensors.size()) + " tensors)");
  if (d.input_tensor == d.output_tensor) return fault(file, "META", "input and output are the same tensor");
  const TensorDesc& in = d.tensors[d.input_tensor];
  const TensorDesc& out = d.tensors[d.output_tensor];
  if (in.dtype != DType::kInt8) return fault(file, "META", "input tensor must be int8");
  if (out.dtype != DType::kFloat32) return fault(file, "META", "output tensor must be float32 (softmax probabilities)");
  if (d.input_mean.size() != in.c || d.input_scale.size() != in.c)
    return fault(file, "META", "input normalisation has " + std::to_string(d.input_mean.size()) + " means and " +
                                   std::to_string(d.input_scale.size()) + " scales for " + std::to_string(in.c) + " input channels");
  for (std::size_t c = 0; c < in.c; ++c)
    if (!std::isfinite(d.input_mean[c]) || !std::isfinite(d.input_scale[c]) || d.input_scale[c] == 0.0f)
      return fault(file, "META", "input normalisation of channel " + std::to_string(c) + " is not finite or has scale 0");
  if (d.class_names.empty() || d.class_names.size() > kMaxClasses)
    return fault(file, "META", std::to_string(d.class_names.size()) + " classes, allowed 1.." + std::to_string(kMaxClasses));
  if (d.class_names.size() != out.c)
    return fault(file, "META", std::to_string(d.class_names.size()) + " class names but the output has " + std::to_string(out.c) + " channels");
  for (std::size_t i = 0; i < d.class_names.size(); ++i)
    if (d.class_names[i].empty() || d.class_names[i].size() > kMaxClassNameBytes)
      return fault(file, "META", "class " + std::to_string(i) + " name empty or longer than " + std::to_string(kMaxClassNameBytes) + " bytes");
  EF_RETURN_IF_ERROR(check_class_map(d, file));

  // Layers: indices, order (no forward references, hence no cycles), single producer.
  if (d.layers.empty() || d.layers.size() > kMaxLayers)
    return fault(file, "LAYR", std::to_string(d.layers.size()) + " layers, allowed 1.." + std::to_string(kMaxLayers));
  std::vector<char> produced(d.tensors.size(), 0);
  produced[d.input_tensor] = 1;
  Model model;
  model.prepared.resize(d.layers.size());
  for (std::size_t li = 0; li < d.layers.size(); ++li) {
    const LayerDesc& l = d.layers[li];
    if (static_cast<uint8_t>(l.type) >= kNumLayerTypes)
      return fault(file, "LAYR", "layer " + std::to_string(li) + ": unknown type " + std::to_string(int(l.type)));
    const std::string where = layer_prefix(li, l.type);
    if (static_cast<uint8_t>(l.act) > static_cast<uint8_t>(Activation::kClamp))
      return fault(file, "LAYR", where + "unknown activation " + std::to_string(int(l.act)));
    if (l.inputs.empty()) return fault(file, "LAYR", where + "no inputs");
    for (uint32_t t : l.inputs) {
      if (t >= d.tensors.size())
        return fault(file, "LAYR", where + "input tensor " + std::to_string(t) + " out of range (" + std::to_string(d.tensors.size()) + " tensors)");
      if (!produced[t])
        return fault(file, "LAYR", where + "input tensor " + std::to_string(t) + " is not produced by an earlier layer (forward reference or cycle)");
    }
    if (l.output >= d.tensors.size())
      return fault(file, "LAYR", where + "output tensor " + std::to_string(l.output) + " out of range (" + std::to_string(d.tensors.size()) + " tensors)");
    if (produced[l.output])
      return fault(file, "LAYR", where + "output tensor " + std::to_string(l.output) + " is already produced (graph input or earlier layer)");
    EF_RETURN_IF_ERROR(check_layer(d, li, file, model.prepared[li]));
    produced[l.output] = 1;
  }
  if (!produced[d.output_tensor]) return fault(file, "LAYR", "no layer produces the output tensor " + std::to_string(d.output_tensor));
  model.source = file;
  model.desc = std::move(d);
  return model;
}

// -----------------------------------------------------------------------------------------------
Result<std::string> serialize_model(const ModelDesc& desc) {
  EF_RETURN_IF_ERROR(prepare_model(desc, "<" + desc.name + ">"));
  std::string bytes = serialize_model_unchecked(desc);
  if (bytes.size() - kEfmHeaderBytes > kMaxPayloadBytes)
    return error(ErrorCode::kInvalidArgument, "<" + desc.name + ">: payload larger than " + std::to_string(kMaxPayloadBytes) + " bytes");
  return bytes;
}

std::string serialize_model_unchecked(const ModelDesc& desc) {
  Writer meta, tens, layr, wght, cmap;
  meta.u16(static_cast<uint16_t>(desc.name.size()));
  meta.bytes(desc.name.data(), desc.name.size());
  meta.u32(desc.input_tensor);
  meta.u32(desc.output_tensor);
  meta.u32(static_cast<uint32_t>(desc.input_mean.size()));
  for (float v : desc.input_mean) meta.f32(v);
  for (float v : desc.input_scale) meta.f32(v);
  meta.u32(static_cast<uint32_t>(desc.class_names.size()));
  for (const auto& n : desc.class_names) { meta.u8(static_cast<uint8_t>(n.size())); meta.bytes(n.data(), n.size()); }

  tens.u32(static_cast<uint32_t>(desc.tensors.size()));
  for (const auto& t : desc.tensors) {
    tens.u8(static_cast<uint8_t>(t.dtype)); tens.u8(0); tens.u8(0); tens.u8(0);
    tens.u32(t.n); tens.u32(t.h); tens.u32(t.w); tens.u32(t.c);
    tens.f32(t.scale); tens.i32(t.zero_point);
  }

  layr.u32(static_cast<uint32_t>(desc.layers.size()));
  for (const auto& l : desc.layers) {
    layr.u8(static_cast<uint8_t>(l.type)); layr.u8(static_cast<uint8_t>(l.act));
    layr.u8(static_cast<uint8_t>(l.mode)); layr.u8(static_cast<uint8_t>(l.inputs.size()));
    layr.u32(l.output);
    for (uint32_t t : l.inputs) layr.u32(t);
    for (uint32_t v : {l.kernel_h, l.kernel_w, l.stride_h, l.stride_w, l.dilation_h, l.dilation_w, l.pad_top, l.pad_left,
                       l.pad_bottom, l.pad_right})
      layr.u32(v);
    layr.i32(l.out_min); layr.i32(l.out_max); layr.u32(l.factor);
    if (has_weights(l.type)) {
      wght.pad4();
      const std::size_t offset = wght.str().size();
      for (float s : l.weight_scales) wght.f32(s);
      for (int32_t b : l.bias) wght.i32(b);
      wght.bytes(l.weights.data(), l.weights.size());
      layr.u32(static_cast<uint32_t>(offset));
      layr.u32(static_cast<uint32_t>(wght.str().size() - offset));
    } else {
      layr.u32(0); layr.u32(0);
    }
  }

  // Version 2 only with a class map, so that a model without one keeps its version 1 bytes.
  const bool has_map = !desc.class_map.empty() || !desc.target_class_names.empty();
  if (has_map) {
    cmap.u32(static_cast<uint32_t>(desc.target_class_names.size()));
    for (const auto& n : desc.target_class_names) { cmap.u8(static_cast<uint8_t>(n.size())); cmap.bytes(n.data(), n.size()); }
    cmap.u32(static_cast<uint32_t>(desc.class_map.size()));
    cmap.bytes(desc.class_map.data(), desc.class_map.size());
  }

  Writer payload;
  const std::pair<uint32_t, Writer*> sections[] = {
      {kTagMeta, &meta}, {kTagTens, &tens}, {kTagLayr, &layr}, {kTagWght, &wght}, {kTagCmap, &cmap}};
  for (const auto& [tag, w] : sections) {
    if (tag == kTagCmap && !has_map) break;
    payload.u32(tag);
    payload.u32(static_cast<uint32_t>(w->str().size()));
    payload.bytes(w->str().data(), w->str().size());
  }
  Writer file;
  file.bytes(kEfmMagic, 4);
  file.u32(has_map ? kEfmVersionClassMap : kEfmVersion);
  file.u32(static_cast<uint32_t>(payload.str().size()));
  file.u32(crc32(payload.str().data(), payload.str().size()));
  file.bytes(payload.str().data(), payload.str().size());
  return std::move(file.str());
}

// -----------------------------------------------------------------------------------------------
Result<Model> load_model_memory(const void* bytes, std::size_t size, const std::string& file) {
  const auto* p = static_cast<const unsigned char*>(bytes);
  if (p == nullptr || size < kEfmHeaderBytes)
    return fault(file, "header", "truncated: " + std::to_string(size) + " bytes, the header alone is " + std::to_string(kEfmHeaderBytes));
  if (std::memcmp(p, kEfmMagic, 4) != 0) return fault(file, "header", "bad magic (not an .efm file)");
  Reader hdr(p + 4, kEfmHeaderBytes - 4);
  uint32_t version = 0, payload_size = 0, crc = 0;
  (void)(hdr.u32(version) && hdr.u32(payload_size) && hdr.u32(crc));
  if (version != kEfmVersion && version != kEfmVersionClassMap)
    return error(ErrorCode::kUnsupported, file + ": header: version " + std::to_string(version) + ", this build reads " +
                                              std::to_string(kEfmVersion) + " and " + std::to_string(kEfmVersionClassMap));
  if (payload_size > kMaxPayloadBytes) return fault(file, "header", "payload size " + std::to_string(payload_size) + " above the limit");
  if (size - kEfmHeaderBytes != payload_size)
    return fault(file, "header", "payload size " + std::to_string(payload_size) + " but the file holds " +
                                     std::to_string(size - kEfmHeaderBytes) + " bytes after the header (truncated or trailing data)");
  const unsigned char* payload = p + kEfmHeaderBytes;
  if (crc32(payload, payload_size) != crc) return fault(file, "header", "payload CRC32 mismatch (corrupt file)");

  // Sections, in their fixed order: four in version 1, the class map fifth in version 2.
  const uint32_t tags[5] = {kTagMeta, kTagTens, kTagLayr, kTagWght, kTagCmap};
  const char* names[5] = {"META", "TENS", "LAYR", "WGHT", "CMAP"};
  const int sections = version == kEfmVersionClassMap ? 5 : 4;
  Reader top(payload, payload_size);
  Reader body[5] = {{nullptr, 0}, {nullptr, 0}, {nullptr, 0}, {nullptr, 0}, {nullptr, 0}};
  for (int s = 0; s < sections; ++s) {
    uint32_t tag = 0, len = 0;
    if (!top.u32(tag) || !top.u32(len)) return fault(file, names[s], "truncated section header");
    if (tag != tags[s]) return fault(file, names[s], "expected section " + std::string(names[s]) + " here (sections must come in order)");
    if (len > top.left()) return fault(file, names[s], "length " + std::to_string(len) + " runs past the payload");
    body[s] = Reader(payload + top.pos(), len);
    uint8_t skip;
    for (uint32_t i = 0; i < len; ++i) (void)top.u8(skip);
  }
  if (top.left() != 0) return fault(file, "payload", std::to_string(top.left()) + " bytes after the last section");

  ModelDesc d;
  const auto trunc = [&](const char* sec, const std::string& what) { return fault(file, sec, "truncated " + what); };
  // META
  {
    Reader& r = body[0];
    uint16_t name_len = 0;
    if (!r.u16(name_len)) return trunc("META", "model name");
    if (name_len > kMaxNameBytes) return fault(file, "META", "model name longer than " + std::to_string(kMaxNameBytes) + " bytes");
    d.name.resize(name_len);
    if (!r.bytes(d.name.data(), name_len)) return trunc("META", "model name");
    uint32_t channels = 0;
    if (!r.u32(d.input_tensor) || !r.u32(d.output_tensor) || !r.u32(channels)) return trunc("META", "tensor ids");
    if (channels > kMaxDim) return fault(file, "META", std::to_string(channels) + " input channels");
    if (uint64_t{channels} * 8 > r.left()) return trunc("META", "input normalisation");
    d.input_mean.resize(channels);
    d.input_scale.resize(channels);
    for (auto& v : d.input_mean) (void)r.f32(v);
    for (auto& v : d.input_scale) (void)r.f32(v);
    uint32_t classes = 0;
    if (!r.u32(classes)) return trunc("META", "class count");
    if (classes > kMaxClasses) return fault(file, "META", std::to_string(classes) + " classes, allowed 1.." + std::to_string(kMaxClasses));
    d.class_names.resize(classes);
    for (uint32_t i = 0; i < classes; ++i) {
      uint8_t len = 0;
      if (!r.u8(len)) return trunc("META", "class name " + std::to_string(i));
      d.class_names[i].resize(len);
      if (!r.bytes(d.class_names[i].data(), len)) return trunc("META", "class name " + std::to_string(i));
    }
    if (r.left() != 0) return fault(file, "META", std::to_string(r.left()) + " unexpected bytes at the end");
  }
  // TENS
  {
    Reader& r = body[1];
    uint32_t count = 0;
    if (!r.u32(count)) return trunc("TENS", "tensor count");
    if (count > kMaxTensors) return fault(file, "TENS", std::to_string(count) + " tensors, allowed 1.." + std::to_string(kMaxTensors));
    if (uint64_t{count} * 28 != r.left())
      return fault(file, "TENS", "section holds " + std::to_string(r.left()) + " bytes for " + std::to_string(count) + " tensors of 28 bytes");
    d.tensors.resize(count);
    for (uint32_t i = 0; i < count; ++i) {
      TensorDesc& t = d.tensors[i];
      uint8_t dtype = 0, reserved[3];
      (void)(r.u8(dtype) && r.bytes(reserved, 3) && r.u32(t.n) && r.u32(t.h) && r.u32(t.w) && r.u32(t.c) && r.f32(t.scale) &&
             r.i32(t.zero_point));
      if (dtype > 1) return fault(file, "TENS", "tensor " + std::to_string(i) + ": unknown dtype " + std::to_string(dtype));
      t.dtype = static_cast<DType>(dtype);
    }
  }
  // LAYR (weights copied from WGHT as each layer is read)
  {
    Reader& r = body[2];
    const Reader& w = body[3];  // untouched: pos 0, left() = section length
    uint32_t count = 0;
    if (!r.u32(count)) return trunc("LAYR", "layer count");
    if (count > kMaxLayers) return fault(file, "LAYR", std::to_string(count) + " layers, allowed 1.." + std::to_string(kMaxLayers));
    // Each layer takes at least 68 bytes: refuse a count the section cannot hold before allocating.
    if (uint64_t{count} * 68 > r.left()) return trunc("LAYR", "layer table (" + std::to_string(count) + " layers)");
    d.layers.resize(count);
    for (uint32_t i = 0; i < count; ++i) {
      LayerDesc& l = d.layers[i];
      const std::string where = "layer " + std::to_string(i) + ": ";
      uint8_t type = 0, act = 0, mode = 0, nin = 0;
      if (!(r.u8(type) && r.u8(act) && r.u8(mode) && r.u8(nin) && r.u32(l.output))) return trunc("LAYR", where + "record");
      if (type >= kNumLayerTypes) return fault(file, "LAYR", where + "unknown type " + std::to_string(type));
      l.type = static_cast<LayerType>(type);
      l.act = static_cast<Activation>(act);
      l.mode = static_cast<UpsampleMode>(mode);
      if (nin > kMaxLayerInputs) return fault(file, "LAYR", layer_prefix(i, l.type) + std::to_string(nin) + " inputs, at most " + std::to_string(kMaxLayerInputs));
      l.inputs.resize(nin);
      for (auto& t : l.inputs)
        if (!r.u32(t)) return trunc("LAYR", where + "inputs");
      uint32_t* fields[] = {&l.kernel_h, &l.kernel_w, &l.stride_h, &l.stride_w, &l.dilation_h, &l.dilation_w,
                            &l.pad_top, &l.pad_left, &l.pad_bottom, &l.pad_right};
      for (uint32_t* f : fields)
        if (!r.u32(*f)) return trunc("LAYR", where + "parameters");
      uint32_t woff = 0, wbytes = 0;
      if (!(r.i32(l.out_min) && r.i32(l.out_max) && r.u32(l.factor) && r.u32(woff) && r.u32(wbytes)))
        return trunc("LAYR", where + "parameters");
      if (!has_weights(l.type)) {
        if (woff != 0 || wbytes != 0) return fault(file, "WGHT", layer_prefix(i, l.type) + "has a weight block but takes no weights");
        continue;
      }
      // The weight block: f32 scale[Cout], i32 bias[Cout], i8 weights[Cout * K]. Its expected size
      // needs the output and input shapes, whose indices are checked here before use.
      const std::string lw = layer_prefix(i, l.type);
      if (l.output >= d.tensors.size() || l.inputs.empty() || l.inputs[0] >= d.tensors.size())
        return fault(file, "LAYR", lw + "tensor index out of range (" + std::to_string(d.tensors.size()) + " tensors)");
      if (woff % 4 != 0) return fault(file, "WGHT", lw + "weight offset " + std::to_string(woff) + " not a multiple of 4");
      if (woff > w.left() || wbytes > w.left() - woff)
        return fault(file, "WGHT", lw + "weight block [" + std::to_string(woff) + ", +" + std::to_string(wbytes) +
                                        ") outside the section (" + std::to_string(w.left()) + " bytes)");
      // The block is split by the output channel count alone; whether the number of weights fits the
      // layer's shapes is checked with the layer (prepare_model), after its shapes are checked.
      const uint64_t cout = d.tensors[l.output].c;
      if (cout * 8 > wbytes)
        return fault(file, "WGHT", lw + "weight block of " + std::to_string(wbytes) + " bytes is too small for the " +
                                        std::to_string(cout * 8) + " bytes of scales and biases");
      const unsigned char* wp = w.data() + woff;
      l.weight_scales.resize(cout);
      l.bias.resize(cout);
      l.weights.resize(wbytes - cout * 8);
      if (cout == 0) continue;  // a zero-channel tensor: rejected with the tensors (prepare_model)
      std::memcpy(l.weight_scales.data(), wp, cout * 4);  // little-endian host (x86-64, AArch64)
      std::memcpy(l.bias.data(), wp + cout * 4, cout * 4);
      if (!l.weights.empty()) std::memcpy(l.weights.data(), wp + cout * 8, l.weights.size());
    }
    if (r.left() != 0) return fault(file, "LAYR", std::to_string(r.left()) + " unexpected bytes at the end");
  }
  // CMAP (version 2): target class names, then one target class per output channel.
  if (sections == 5) {
    Reader& r = body[4];
    uint32_t targets = 0;
    if (!r.u32(targets)) return trunc("CMAP", "target class count");
    if (targets < 1 || targets > kMaxClasses)
      return fault(file, "CMAP", std::to_string(targets) + " target classes, allowed 1.." + std::to_string(kMaxClasses));
    d.target_class_names.resize(targets);
    for (uint32_t i = 0; i < targets; ++i) {
      uint8_t len = 0;
      if (!r.u8(len)) return trunc("CMAP", "target class name " + std::to_string(i));
      d.target_class_names[i].resize(len);
      if (!r.bytes(d.target_class_names[i].data(), len)) return trunc("CMAP", "target class name " + std::to_string(i));
    }
    uint32_t entries = 0;
    if (!r.u32(entries)) return trunc("CMAP", "map entry count");
    if (entries < 1 || entries > kMaxClasses)
      return fault(file, "CMAP", std::to_string(entries) + " map entries, allowed 1.." + std::to_string(kMaxClasses));
    d.class_map.resize(entries);
    if (!r.bytes(d.class_map.data(), entries)) return trunc("CMAP", "class map");
    if (r.left() != 0) return fault(file, "CMAP", std::to_string(r.left()) + " unexpected bytes at the end");
  }
  return prepare_model(std::move(d), file);
}

Result<Model> load_model(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return error(ErrorCode::kNotFound, path + ": cannot open");
  f.seekg(0, std::ios::end);
  const std::streamoff size = f.tellg();
  if (size < 0) return error(ErrorCode::kIoError, path + ": cannot read its size");
  if (static_cast<uint64_t>(size) > kMaxPayloadBytes + kEfmHeaderBytes)
    return fault(path, "header", "file of " + std::to_string(size) + " bytes is above the size limit");
  f.seekg(0, std::ios::beg);
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (!f.read(bytes.data(), size)) return error(ErrorCode::kIoError, path + ": read failed");
  return load_model_memory(bytes.data(), bytes.size(), path);
}

std::size_t Model::bytes() const {
  std::size_t b = 0;
  for (const LayerDesc& l : desc.layers)
    b += l.weights.size() + l.bias.size() * sizeof(int32_t) + l.weight_scales.size() * sizeof(float);
  for (const PreparedLayer& p : prepared)
    b += p.requant.size() * sizeof(Requant) + p.packed.size() + p.bias.size() * sizeof(int32_t) +
         p.exp_table.size() * sizeof(float) + p.resize_taps.size() * sizeof(ResizeTap);
  b += desc.class_map.size();
  for (const std::string& n : desc.target_class_names) b += n.size();
  b += desc.tensors.size() * sizeof(TensorDesc) + desc.layers.size() * sizeof(LayerDesc);
  return b;
}

}  // namespace ef::nn
