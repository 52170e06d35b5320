// The .efm model file (docs/model_format.md): what it describes (ModelDesc), a writer, and a
// loader that validates everything and prepares a Model (requantisation multipliers computed,
// weights repacked, resize taps tabulated) ready for the executor. Version 1 has four sections;
// version 2 is version 1 plus a fifth, the class map (CMAP). The writer emits version 1 for a model
// without a class map (the same bytes as before version 2 existed) and version 2 otherwise.
//
// Threads: every function here is re-entrant; a Model is immutable after load and may be shared by
// executors on several threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "nn/requantize.h"
#include "nn/resize_taps.h"

namespace ef::nn {

inline constexpr char kEfmMagic[4] = {'E', 'F', 'M', '1'};
inline constexpr uint32_t kEfmVersion = 1;          // META, TENS, LAYR, WGHT
inline constexpr uint32_t kEfmVersionClassMap = 2;  // the same plus CMAP (ModelDesc::class_map)
inline constexpr std::size_t kEfmHeaderBytes = 16;  // magic, version, payload size, payload CRC32

// Limits the loader enforces (so that sizes cannot overflow and a hostile file cannot ask for
// gigabytes). Each is far above what a SemanticFusion-sized network needs.
inline constexpr uint32_t kMaxPayloadBytes = 256u << 20;  // 256 MiB
inline constexpr uint32_t kMaxTensors = 4096;
inline constexpr uint32_t kMaxLayers = 4096;
inline constexpr uint32_t kMaxDim = 8192;            // H, W and C each
inline constexpr uint64_t kMaxTensorElements = 64u << 20;
inline constexpr uint32_t kMaxClasses = 256;
inline constexpr uint32_t kMaxNameBytes = 255;       // model name
inline constexpr uint32_t kMaxClassNameBytes = 63;
inline constexpr uint32_t kMaxKernel = 31;           // kernel height / width
// A global average pool (window = the input's H x W, stride 1, no padding) may be larger than
// kMaxKernel, up to this per side: its int32 sum stays below 255 * 256 * 256 < 2^31, and it needs
// one multiplier only (PreparedLayer::requant), so no table grows with the window.
inline constexpr uint32_t kMaxGlobalPool = 256;
inline constexpr uint32_t kMaxStride = 8;
inline constexpr uint32_t kMaxDilation = 16;
inline constexpr uint32_t kMaxPad = 64;
inline constexpr uint32_t kMaxUpsample = 16;
inline constexpr uint32_t kMaxLayerInputs = 16;      // concatenate
inline constexpr uint32_t kMaxReduction = 32768;     // kh * kw * Cin of one output: int32 never overflows
inline constexpr int32_t kMaxAbsBias = 1 << 30;

enum class DType : uint8_t { kInt8 = 0, kFloat32 = 1 };

enum class LayerType : uint8_t {
  kConv2d = 0,          // k x k, stride, dilation, explicit padding; weights [Cout][kh][kw][Cin]
  kDepthwiseConv2d = 1, // channel multiplier 1; weights [C][kh][kw]
  kPointwiseConv2d = 2, // 1 x 1, stride 1, no padding; weights [Cout][Cin]
  kAdd = 3,             // two inputs of one shape
  kConcat = 4,          // along channels, 1..16 inputs
  kClamp = 5,           // ReLU / ReLU6 / clamp, same quantisation in and out
  kMaxPool = 6,
  kAvgPool = 7,         // the average over the window positions inside the input
  kUpsample = 8,        // integer factor, nearest or bilinear (half-pixel centres)
  kSoftmax = 9,         // the output stage: int8 logits -> float probabilities over channels
  kResizeBilinear = 10, // to the output's H x W (any size), align_corners; same quantisation in and out
};
inline constexpr uint8_t kNumLayerTypes = 11;
const char* layer_type_name(LayerType t);

// What the out_min/out_max range of a layer stands for. Informative only: the arithmetic uses the
// integer range, which the exporter computes (docs/model_format.md).
enum class Activation : uint8_t { kNone = 0, kRelu = 1, kRelu6 = 2, kClamp = 3 };

enum class UpsampleMode : uint8_t { kNearest = 0, kBilinear = 1 };

struct TensorDesc {
  DType dtype = DType::kInt8;
  uint32_t n = 1, h = 1, w = 1, c = 1;  // NHWC; n must be 1
  float scale = 1.0f;                    // real = scale * (q - zero_point); float32 tensors: 1
  int32_t zero_point = 0;                // [-128, 127]; float32 tensors: 0
  uint64_t elements() const { return uint64_t{n} * h * w * c; }
};

// One layer. Fields that a layer type does not use are ignored by the loader (the writer puts the
// defaults there).
struct LayerDesc {
  LayerType type = LayerType::kConv2d;
  Activation act = Activation::kNone;
  std::vector<uint32_t> inputs;  // tensor ids
  uint32_t output = 0;           // tensor id
  // Convolutions and pools.
  uint32_t kernel_h = 1, kernel_w = 1;
  uint32_t stride_h = 1, stride_w = 1;
  uint32_t dilation_h = 1, dilation_w = 1;  // convolutions only
  uint32_t pad_top = 0, pad_left = 0, pad_bottom = 0, pad_right = 0;
  // Output range with the activation folded in: conv, add, clamp.
  int32_t out_min = -128, out_max = 127;
  // Upsample.
  uint32_t factor = 1;
  UpsampleMode mode = UpsampleMode::kNearest;
  // Convolutions: per output channel weight scale (float32 > 0) and int32 bias (in units of
  // in_scale * weight_scale); int8 weights in [-127, 127] (symmetric), layout per type above.
  std::vector<float> weight_scales;
  std::vector<int32_t> bias;
  std::vector<int8_t> weights;
};

struct ModelDesc {
  std::string name;
  // Input normalisation per input channel (R, G, B, depth): normalised = (value - mean) * scale.
  // Colour values are in [0, 255], depth in metres (0 = invalid).
  std::vector<float> input_mean;
  std::vector<float> input_scale;
  std::vector<std::string> class_names;  // one per output channel
  // Optional (version 2 files): the class each output channel contributes to in the runtime's label
  // set (e.g. 0 = unknown, 1..13 the NYUv2 classes of core/classes.h), so that a network with more
  // outputs than the fusion has classes (ADE20K's 151) can feed it: the probabilities of the channels
  // mapping to a class are summed. Empty: output channel k is class k. Otherwise one entry per
  // output channel, each < target_class_names.size() (<= kMaxClasses), and target_class_names names
  // the target classes (1..kMaxClassNameBytes bytes each); both empty or both non-empty.
  std::vector<uint8_t> class_map;
  std::vector<std::string> target_class_names;
  uint32_t input_tensor = 0;
  uint32_t output_tensor = 0;
  std::vector<TensorDesc> tensors;  // id = index
  std::vector<LayerDesc> layers;    // run in this order
};

// IEEE 802.3 CRC-32 (zlib's crc32, Python's zlib.crc32) of `size` bytes.
uint32_t crc32(const void* data, std::size_t size);

// Layer data derived at load: multipliers, repacked weights, tables. See docs/model_format.md.
struct PreparedLayer {
  std::vector<Requant> requant;    // conv: per output channel; add: 2 (one per input); concat: per
                                   // input; avgpool: entry k-1 for a window of k positions, or one
                                   // entry (the count kh*kw) for a global pool (is_global_pool)
  std::vector<int8_t> packed;      // weights in the file layout (the executor repacks them per kernel variant)
  std::vector<int32_t> bias;
  std::vector<float> exp_table;    // softmax: 256 entries, exp(-scale * d)
  std::vector<ResizeTap> resize_taps;  // resize_bilinear: out.h row taps, then out.w column taps
};

// True when avg_pool layer `l` on input `in` is a global pool: the window is the input's H x W, with
// stride 1 and no padding (one output pixel, one window count).
bool is_global_pool(const LayerDesc& l, const TensorDesc& in);

// A validated model.
struct Model {
  std::string source;  // file name (or the name given to load_model_memory), used in messages
  ModelDesc desc;
  std::vector<PreparedLayer> prepared;  // one per layer

  // Bytes of its arrays: the file's weights, biases and scales, their prepared copies
  // (requantisation, packed weights, biases, tables, resize taps), the class map and the tensor and
  // layer tables.
  std::size_t bytes() const;
};

// Writes the .efm bytes of `desc` (version 1, or 2 when it has a class map). Validates first (the same checks as the loader), so that a
// writer can never produce a file the loader refuses; the error names "<desc.name>" as the file.
Result<std::string> serialize_model(const ModelDesc& desc);

// Writes the bytes without validating: for tests and fuzz seeds that need malformed files. Still
// never reads out of bounds of `desc` (counts are those of its vectors).
std::string serialize_model_unchecked(const ModelDesc& desc);

// Reads and validates a .efm file. Every error names the file, the section, the layer or tensor
// index and the fault, e.g. "net.efm: LAYR: layer 3 (conv2d): input tensor 17 out of range (12 tensors)".
Result<Model> load_model(const std::string& path);
Result<Model> load_model_memory(const void* bytes, std::size_t size, const std::string& name);

// The validation and preparation alone (used by both of the above and by serialize_model).
Result<Model> prepare_model(ModelDesc desc, const std::string& source);

}  // namespace ef::nn
