#include "semantic/segmenter.h"

#include <algorithm>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "core/stopwatch.h"
#include "io/frame_resample.h"

namespace ef::semantic {

namespace {

constexpr int kRgbChannels = 3;   // R, G, B (0..255)
constexpr int kRgbdChannels = 4;  // R, G, B (0..255), depth (metres)


// OpenCV's INTER_AREA shrink by integer factors (fx, fy) (resizeAreaFast, what resample_frame runs
// for 640x480 -> 160x120) keeps a table of fx * fy + 3 * dst_width ints in a cv::AutoBuffer whose
// in-object storage holds 1024 / sizeof(int) + 8 = 264 ints; a larger table is taken from the heap
// on every call. Each output pixel of that path depends only on its own fx x fy block (the 2 x 2
// vector path and its scalar tail round alike), so resizing vertical strips of output columns
// narrow enough for the in-object storage gives the bytes of one call without the allocation.
constexpr int kOpenCvAreaTableInts = 1024 / int(sizeof(int)) + 8;

}  // namespace

int Segmenter::classes_for(const nn::Model& model) {
  const nn::ModelDesc& d = model.desc;
  return d.class_map.empty() ? int(d.tensors[d.output_tensor].c) : int(d.target_class_names.size());
}

Result<std::unique_ptr<Segmenter>> Segmenter::create(const std::string& model_path, const SegmenterOptions& options) {
  EF_ASSIGN_OR_RETURN(nn::Model model, nn::load_model(model_path));
  std::unique_ptr<Segmenter> s(new Segmenter());
  s->owned_model_ = std::make_unique<nn::Model>(std::move(model));
  s->model_ = s->owned_model_.get();
  return prepare(std::move(s), options);
}

Result<std::unique_ptr<Segmenter>> Segmenter::create(const nn::Model& model, const SegmenterOptions& options) {
  std::unique_ptr<Segmenter> s(new Segmenter());
  s->model_ = &model;
  return prepare(std::move(s), options);
}

Segmenter::~Segmenter() = default;

Result<std::unique_ptr<Segmenter>> Segmenter::prepare(std::unique_ptr<Segmenter> s, const SegmenterOptions& options) {
  const nn::ModelDesc& d = s->model_->desc;
  const std::string& file = s->model_->source;
  // The loader has validated indices and shapes; what is checked here is what this class assumes
  // on top: an RGB-D input and class ids that fit a uint8_t label image.
  const nn::TensorDesc& in = d.tensors[d.input_tensor];
  const nn::TensorDesc& out = d.tensors[d.output_tensor];
  if (in.c != kRgbChannels && in.c != kRgbdChannels)
    return error(ErrorCode::kUnsupported, file + ": segmenter: the input has " + std::to_string(in.c) +
                                              " channels; expected 3 (R, G, B) or 4 (R, G, B, depth)");
  if (out.dtype != nn::DType::kFloat32 || out.c < 1 || out.c > 256)
    return error(ErrorCode::kUnsupported, file + ": segmenter: the output must be float32 probabilities over 1..256 "
                                                 "classes (it has " + std::to_string(out.c) + ")");
  s->in_w_ = int(in.w);
  s->in_h_ = int(in.h);
  s->in_c_ = int(in.c);
  s->out_w_ = int(out.w);
  s->out_h_ = int(out.h);
  s->net_classes_ = int(out.c);
  s->num_classes_ = Segmenter::classes_for(*s->model_);
  if (s->num_classes_ > 256)
    return error(ErrorCode::kUnsupported, file + ": segmenter: " + std::to_string(s->num_classes_) +
                                              " target classes; class ids must fit 8 bits");

  if (needs_area_resampler(options.frame_width, options.frame_height, s->in_w_, s->in_h_)) {
    auto area = AreaResampler::create(options.frame_width, options.frame_height, s->in_w_, s->in_h_);
    if (!area.ok()) return area.take_error();
    s->area_.emplace(std::move(*area));
  }

  nn::ExecutorOptions eo;
  eo.pool = options.pool;
  eo.max_isa = options.max_isa;
  EF_ASSIGN_OR_RETURN(s->executor_, nn::Executor::create(*s->model_, eo));

  // Every per-frame buffer, once. The resampled frame has no label image: labels of the source are
  // not an input of the network.
  s->resampled_.allocate(s->in_w_, s->in_h_, /*with_labels=*/false);
  s->depth_only_.depth.allocate(s->in_w_, s->in_h_);
  s->depth_only_.name.reserve(Frame::kMaxFrameName);
  s->input_.assign(s->executor_->input_floats(), 0.0f);
  const std::size_t out_px = std::size_t(s->out_w_) * std::size_t(s->out_h_);
  if (!d.class_map.empty()) s->net_probs_.assign(s->executor_->output_floats(), 0.0f);
  s->probs_.assign(out_px * std::size_t(s->num_classes_), 0.0f);
  s->labels_.allocate(s->out_w_, s->out_h_);
  if (s->input_.size() != std::size_t(s->in_w_) * std::size_t(s->in_h_) * std::size_t(s->in_c_) ||
      s->executor_->output_floats() != out_px * std::size_t(s->net_classes_))
    return error(ErrorCode::kInternal, file + ": segmenter: executor buffer sizes disagree with the model's tensors");
  // The memory plan sizes this object by buffer_bytes_for(): the two must never disagree.
  const std::size_t planned = buffer_bytes_for(*s->model_, options.frame_width, options.frame_height);
  if (s->buffer_bytes() != planned)
    return error(ErrorCode::kInternal, file + ": segmenter: allocated " + std::to_string(s->buffer_bytes()) +
                                           " buffer bytes, buffer_bytes_for() says " + std::to_string(planned));
  return s;
}

bool Segmenter::needs_area_resampler(int frame_w, int frame_h, int in_w, int in_h) {
  if (frame_w <= 0 || frame_h <= 0 || (frame_w == in_w && frame_h == in_h)) return false;
  const bool integer_shrink = frame_w % in_w == 0 && frame_h % in_h == 0 &&
                              kOpenCvAreaTableInts - (frame_w / in_w) * (frame_h / in_h) >= 3;
  return !integer_shrink;  // the strips of resample_in_strips() do those without allocating
}

std::size_t Segmenter::buffer_bytes_for(const nn::Model& model, int frame_width, int frame_height) {
  const nn::ModelDesc& d = model.desc;
  const nn::TensorDesc& in = d.tensors[d.input_tensor];
  const nn::TensorDesc& out = d.tensors[d.output_tensor];
  const std::size_t in_px = std::size_t(in.w) * std::size_t(in.h), out_px = std::size_t(out.w) * std::size_t(out.h);
  const std::size_t net_probs = d.class_map.empty() ? 0 : out_px * std::size_t(out.c);
  const std::size_t area = needs_area_resampler(frame_width, frame_height, int(in.w), int(in.h))
                               ? AreaResampler::bytes_for(frame_width, frame_height, int(in.w), int(in.h))
                               : 0;
  return area + Frame::bytes_for(int(in.w), int(in.h), /*with_labels=*/false) + in_px * sizeof(float) +
         in_px * std::size_t(in.c) * sizeof(float) + (net_probs + out_px * std::size_t(Segmenter::classes_for(model))) * sizeof(float) +
         out_px;
}

std::size_t Segmenter::buffer_bytes() const {
  const std::size_t in_px = std::size_t(in_w_) * std::size_t(in_h_);
  return in_px * (sizeof(Rgb8) + 2 * sizeof(float)) + input_.size() * sizeof(float) +
         (net_probs_.size() + probs_.size()) * sizeof(float) + labels_.size() + (area_ ? area_->bytes() : 0);
}

bool Segmenter::resample_in_strips(const Frame& frame) {
  const int sw = frame.color.width(), sh = frame.color.height();
  if (sw % in_w_ != 0 || sh % in_h_ != 0) return false;
  const int fx = sw / in_w_, fy = sh / in_h_;
  const int strip = (kOpenCvAreaTableInts - fx * fy) / 3;  // output columns per call
  if (strip < 1) return false;
  // Depth (and the metadata) through resample_frame itself: an output frame without a colour image
  // makes it skip the colour, and its depth path never allocates.
  resample_frame(frame, depth_only_);
  // Colour: the same cv::resize call resample_frame makes, strip by strip.
  const cv::Mat src(sh, sw, CV_8UC3, const_cast<Rgb8*>(frame.color.data()));
  cv::Mat dst(in_h_, in_w_, CV_8UC3, resampled_.color.data());
  for (int x0 = 0; x0 < in_w_; x0 += strip) {
    const int w = std::min(strip, in_w_ - x0);
    cv::Mat d = dst.colRange(x0, x0 + w);
    cv::resize(src.colRange(x0 * fx, (x0 + w) * fx), d, d.size(), 0, 0, cv::INTER_AREA);
  }
  return true;
}

void Segmenter::build_input(const Image<Rgb8>& color, const Image<float>& depth) {
  float* dst = input_.data();
  const bool with_depth = in_c_ == kRgbdChannels;
  for (int y = 0; y < in_h_; ++y) {
    const Rgb8* c = color.data() + std::size_t(y) * std::size_t(in_w_);
    const float* z = depth.data() + std::size_t(y) * std::size_t(in_w_);
    for (int x = 0; x < in_w_; ++x) {
      dst[0] = float(c[x].r);
      dst[1] = float(c[x].g);
      dst[2] = float(c[x].b);
      if (with_depth) dst[3] = z[x];
      dst += in_c_;
    }
  }
}

void Segmenter::map_classes() {
  // p(target) = sum of p(source) over the source channels mapped to it (the model's class map), in
  // channel order, so the sum is the same on every machine.
  const std::vector<uint8_t>& map = model_->desc.class_map;
  const std::size_t k_in = std::size_t(net_classes_), k_out = std::size_t(num_classes_);
  const std::size_t n = std::size_t(out_w_) * std::size_t(out_h_);
  const float* src = net_probs_.data();
  float* dst = probs_.data();
  for (std::size_t i = 0; i < n; ++i, src += k_in, dst += k_out) {
    std::fill(dst, dst + k_out, 0.0f);
    for (std::size_t c = 0; c < k_in; ++c) dst[map[c]] += src[c];
  }
}

void Segmenter::argmax() {
  const std::size_t k = std::size_t(num_classes_);
  const float* p = probs_.data();
  uint8_t* l = labels_.data();
  const std::size_t n = std::size_t(out_w_) * std::size_t(out_h_);
  for (std::size_t i = 0; i < n; ++i, p += k) {
    std::size_t best = 0;
    float best_p = p[0];
    for (std::size_t c = 1; c < k; ++c)  // strict '>': the lowest class id wins a tie
      if (p[c] > best_p) best_p = p[c], best = c;
    l[i] = uint8_t(best);
  }
}

void Segmenter::upsample_labels(ImageView<uint8_t> out) const {
  if (out.empty()) return;
  // Source index floor((d + 0.5) * S / D) computed exactly in integers: ((2d + 1) * S) / (2D).
  const int64_t sw = out_w_, sh = out_h_, dw = out.width, dh = out.height;
  for (int y = 0; y < out.height; ++y) {
    int64_t ys = ((2 * int64_t(y) + 1) * sh) / (2 * dh);
    if (ys > sh - 1) ys = sh - 1;
    const uint8_t* src = labels_.data() + std::size_t(ys) * std::size_t(out_w_);
    uint8_t* dst = out.row(y);
    if (dw == sw) {
      std::memcpy(dst, src, std::size_t(dw));
      continue;
    }
    for (int x = 0; x < out.width; ++x) {
      int64_t xs = ((2 * int64_t(x) + 1) * sw) / (2 * dw);
      if (xs > sw - 1) xs = sw - 1;
      dst[x] = src[xs];
    }
  }
}

Status Segmenter::segment(const Frame& frame, ImageView<uint8_t> upsampled) {
  if (frame.color.empty() || frame.depth.empty())
    return error(ErrorCode::kInvalidArgument, "segment: frame " + std::to_string(frame.index) + " ('" + frame.name +
                                                  "'): the network needs colour and depth; the frame has " +
                                                  (frame.color.empty() ? "no colour" : "no depth"));
  if (frame.color.width() != frame.depth.width() || frame.color.height() != frame.depth.height())
    return error(ErrorCode::kInvalidArgument, "segment: frame " + std::to_string(frame.index) + " ('" + frame.name +
                                                  "'): colour " + std::to_string(frame.color.width()) + "x" +
                                                  std::to_string(frame.color.height()) + " and depth " +
                                                  std::to_string(frame.depth.width()) + "x" +
                                                  std::to_string(frame.depth.height()) + " differ in size");
  SteadyClock::time_point t = SteadyClock::now();
  const SteadyClock::time_point start = t;
  timings_ = {};
  // A frame already at the input size is read as it is: resample_frame would copy it unchanged
  // (and `edgefusion convert` does not resample it either).
  const Image<Rgb8>* color = &frame.color;
  const Image<float>* depth = &frame.depth;
  if (frame.color.width() != in_w_ || frame.color.height() != in_h_) {
    color = &resampled_.color;
    if (area_ && frame.color.width() == area_->src_width() && frame.color.height() == area_->src_height()) {
      area_->run(frame.color.view(), resampled_.color.view());
      resample_frame(frame, depth_only_);  // depth alone: this output frame has no colour image
      depth = &depth_only_.depth;
    } else if (resample_in_strips(frame)) {
      depth = &depth_only_.depth;
    } else {
      resample_frame(frame, resampled_);
      depth = &resampled_.depth;
    }
    timings_.resample_ms = lap_ms(t);
  }
  build_input(*color, *depth);
  timings_.input_ms = lap_ms(t);
  if (net_probs_.empty()) {
    EF_RETURN_IF_ERROR(executor_->run(input_.data(), input_.size(), probs_.data(), probs_.size()));
  } else {
    EF_RETURN_IF_ERROR(executor_->run(input_.data(), input_.size(), net_probs_.data(), net_probs_.size()));
    map_classes();
  }
  timings_.forward_ms = lap_ms(t);
  argmax();
  timings_.argmax_ms = lap_ms(t);
  if (!upsampled.empty()) {
    upsample_labels(upsampled);
    timings_.upsample_ms = lap_ms(t);
  }
  timings_.total_ms = ms_since(start);
  return Status::success();
}

Result<kernels::Isa> parse_isa(const std::string& name, const std::string& what) {
  using kernels::Isa;
  for (Isa isa : {Isa::scalar, Isa::sse41, Isa::avx2, Isa::avxvnni, Isa::avx512vnni, Isa::neon, Isa::neondot})
    if (name == kernels::isa_name(isa)) return isa;
  return error(ErrorCode::kInvalidArgument, what + ": unknown ISA '" + name +
                                                "' (expected scalar, sse41, avx2, avxvnni, avx512vnni, neon or neondot)");
}

}  // namespace ef::semantic
