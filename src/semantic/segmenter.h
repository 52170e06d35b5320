// Runs a segmentation network (.efm with an R, G, B, depth input, or R, G, B only) on one frame:
// resample to the network's input size, build the float input, run the int8 executor, and turn the
// class probabilities into class-id images. A model that carries a class map (e.g. ADE20K's 150
// classes -> the NYUv2 13) gives the probabilities of its target classes: each the sum of its source
// classes' probabilities.
//
// Why the resampling is io's resample_frame: the training data is exported with
// `edgefusion convert --resolution`, which calls the same function, so the network sees at run time
// exactly the pixels it was trained on (colour area-averaged, depth block-averaged keeping the near
// surface).
//
// Memory: everything is allocated by create() (the executor's arena and packed weights, the
// resampled frame, the float input, the probabilities and the class-id image); segment() and
// upsample_labels() never touch the heap (tests/semantic/test_segmenter_zero_alloc.cpp) when the frame
// is an integer multiple of the input size with a factor up to 16 (640x480 or 320x240 to 160x120),
// or has the size SegmenterOptions::frame_width/height announced (any ratio: area resampling
// through tables made at creation). Other sizes go through resample_frame as a whole, where
// OpenCV's resize takes scratch memory from the heap on each call.
//
// Ownership: create(path) owns the model it loads; create(model) borrows it (the model must outlive
// the segmenter). The optional thread pool is borrowed too.
// Threads: one segmenter per thread (its buffers are reused frame to frame).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/frame.h"
#include "core/image.h"
#include "core/result.h"
#include "core/thread_pool.h"
#include "io/area_resampler.h"
#include "kernels/variants.h"
#include "nn/executor.h"
#include "nn/model_format.h"

namespace ef::semantic {

struct SegmenterOptions {
  // Highest kernel ISA level the executor may use (enum order of kernels::Isa). Default: every
  // level the CPU and EF_ISA allow. Isa::scalar runs the scalar reference layers.
  kernels::Isa max_isa = kernels::Isa::neondot;
  // Threads that split each convolution by output rows; borrowed, must outlive the segmenter.
  // nullptr (default): the forward pass runs on the calling thread.
  ThreadPool* pool = nullptr;
  // The size of the frames segment() will get, when known (pixels; 0 = unknown). When it is not an
  // integer multiple of the network's input (the 320x240 working frame to the real-camera network's
  // 257x193), the colour is resampled through tables made at creation (io/area_resampler.h)
  // instead of OpenCV, which allocates on every call at such ratios.
  int frame_width = 0, frame_height = 0;
};

// Milliseconds spent in each step of the last segment() call (steady clock).
struct SegmentTimings {
  double resample_ms = 0;  // resample_frame to the input size (0 when the frame already has it)
  double input_ms = 0;     // interleaving R, G, B, depth into the float input
  double forward_ms = 0;   // Executor::run: quantisation, every layer, softmax
  double argmax_ms = 0;    // probabilities -> class ids at the output resolution
  double upsample_ms = 0;  // nearest-neighbour upsampling to the requested size (0 when none)
  double total_ms = 0;
};

// Class probabilities at the network's output resolution: height x width x classes floats,
// classes innermost (element (y, x, k) at (y * width + x) * classes + k), each pixel summing to 1.
struct ProbabilityView {
  const float* data = nullptr;
  int height = 0, width = 0, classes = 0;
  std::size_t floats() const { return std::size_t(height) * std::size_t(width) * std::size_t(classes); }
  const float* pixel(int x, int y) const { return data + (std::size_t(y) * std::size_t(width) + std::size_t(x)) * std::size_t(classes); }
};

class Segmenter {
 public:
  // Loads and validates `model_path` (.efm) and prepares everything. Errors: the loader's (the file,
  // section and fault; kNotFound for a missing file), and kUnsupported for a model this class cannot
  // feed (input not 3 or 4 channels, more than 256 classes, output not float32 HxWxK).
  static Result<std::unique_ptr<Segmenter>> create(const std::string& model_path, const SegmenterOptions& options = {});
  // The same with an already loaded model, borrowed (it must outlive the segmenter).
  static Result<std::unique_ptr<Segmenter>> create(const nn::Model& model, const SegmenterOptions& options = {});

  Segmenter(const Segmenter&) = delete;
  Segmenter& operator=(const Segmenter&) = delete;
  ~Segmenter();

  // Segments `frame` (any size; colour and depth required and of one size). Afterwards
  // probabilities() and labels() hold the network's result for it. When `upsampled` is not empty,
  // the class ids are also written into it by nearest neighbour at its own size (normally the
  // frame's). Errors (kInvalidArgument) name the frame: missing colour or depth, colour and depth of
  // different sizes. Allocates nothing.
  Status segment(const Frame& frame, ImageView<uint8_t> upsampled = {});

  // The class ids of the last segment() at the output resolution, upsampled by nearest neighbour
  // into `out` of any size: out(x, y) = labels(floor((x + 0.5) * W' / W), floor((y + 0.5) * H' / H)),
  // the pixel-centre convention of resample_frame. Allocates nothing.
  void upsample_labels(ImageView<uint8_t> out) const;

  // Results of the last segment(): probabilities over num_classes() (the target classes of a model
  // with a class map).
  ProbabilityView probabilities() const {
    return {probs_.data(), out_h_, out_w_, num_classes_};
  }
  // argmax over the classes of each output pixel (the lowest class id on a tie): class ids.
  ImageView<const uint8_t> labels() const { return labels_.view(); }
  const SegmentTimings& last_timings() const { return timings_; }

  // The float input the network saw last (input_height x input_width x 3 or 4: R, G, B in 0..255,
  // and depth in metres for an RGB-D network). For tests.
  const std::vector<float>& input() const { return input_; }

  int input_width() const { return in_w_; }
  int input_height() const { return in_h_; }
  int output_width() const { return out_w_; }
  int output_height() const { return out_h_; }
  int num_classes() const { return num_classes_; }
  // Name of class k of probabilities(): the model's target class names with a class map, else its
  // output channel names.
  const std::string& class_name(int k) const {
    const nn::ModelDesc& d = model_->desc;
    return d.class_map.empty() ? d.class_names[std::size_t(k)] : d.target_class_names[std::size_t(k)];
  }

  const nn::Model& model() const { return *model_; }
  const nn::Executor& executor() const { return *executor_; }
  // Bytes this segmenter allocated besides the executor (resampled frame, input, probabilities,
  // labels); see docs/architecture.md, memory budget.
  std::size_t buffer_bytes() const;
  // What create() allocates besides the executor for `model` (validated): the resampled frame
  // (colour + depth) and a depth-only frame at the input size, the float input (3 or 4 channels),
  // the probabilities (the network's and, with a class map, the target classes') and the class ids
  // at the output size. The memory plan's "segmenter buffers".
  // frame_width/height: SegmenterOptions' (the area resampler's tables when that size needs them).
  static std::size_t buffer_bytes_for(const nn::Model& model, int frame_width = 0, int frame_height = 0);
  // Classes of the probabilities a segmenter of `model` gives: its class map's target classes, or
  // its output channels when it has none (num_classes()).
  static int classes_for(const nn::Model& model);

 private:
  Segmenter() = default;
  static Result<std::unique_ptr<Segmenter>> prepare(std::unique_ptr<Segmenter> s, const SegmenterOptions& options);
  bool resample_in_strips(const Frame& frame);
  // True when frames of frame_w x frame_h (announced) are resampled to in_w x in_h by AreaResampler.
  static bool needs_area_resampler(int frame_w, int frame_h, int in_w, int in_h);
  void build_input(const Image<Rgb8>& color, const Image<float>& depth);
  void argmax();
  void map_classes();

  std::unique_ptr<nn::Model> owned_model_;  // set by create(path)
  const nn::Model* model_ = nullptr;
  std::unique_ptr<nn::Executor> executor_;
  int in_w_ = 0, in_h_ = 0, in_c_ = 0, out_w_ = 0, out_h_ = 0;
  int net_classes_ = 0;  // the network's output channels
  int num_classes_ = 0;  // classes of probs_: the class map's targets, else net_classes_
  Frame resampled_;                 // the frame at the input size (colour + depth, no labels)
  Frame depth_only_;                // depth at the input size without a colour image (see segment())
  std::optional<AreaResampler> area_;  // announced frames at a non-integer ratio
  std::vector<float> input_;        // in_h x in_w x in_c (R, G, B[, depth])
  std::vector<float> net_probs_;    // out_h x out_w x net_classes_ (only with a class map)
  std::vector<float> probs_;        // out_h x out_w x num_classes_
  Image<uint8_t> labels_;           // out_w x out_h class ids
  SegmentTimings timings_;
};

// Parses a kernel ISA level name ("scalar", "sse41", "avx2", "avxvnni", "avx512vnni", "neon",
// "neondot"); an error names `what` and the accepted names.
Result<kernels::Isa> parse_isa(const std::string& name, const std::string& what);

}  // namespace ef::semantic
