#include "semantic/label_fusion.h"

#include "semantic/label_store.h"

namespace ef::semantic {

namespace {
using slam::kMaxIndexScale;
constexpr int kMaxSide = 16384;

// Nearest neighbour with pixel centres (the segmenter's rule): floor((u + 0.5) * to / from).
int32_t nearest(int64_t u, int64_t from, int64_t to) { return static_cast<int32_t>(((2 * u + 1) * to) / (2 * from)); }
}  // namespace

const opt::Table<LabelFusionOptions>& LabelFusionOptions::table() {
  static const opt::Table<LabelFusionOptions> t = {
      {"every", "label_every", "--label-every", &LabelFusionOptions::update_every_n_frames, "frames",
       opt::between(1, 1'000'000), "how often the CNN's labels are fused: every N-th frame (the paper's 10)"},
      {"visibility", "label_visibility", "", &LabelFusionOptions::visibility_test, "", opt::any(),
       "fuse and render only surfels at the measured depth; false = every index-map surfel"},
  };
  return t;
}

Status LabelFusionOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "label fusion"));
  for (int side : {working_width, working_height, cnn_width, cnn_height})
    if (side < 1 || side > kMaxSide)
      return error(ErrorCode::kInvalidArgument, "label fusion: image sides must be in 1..16384 (" + describe() + ")");
  if (!(visibility.abs_m >= 0.0f && visibility.abs_m <= 10.0f && visibility.rel >= 0.0f && visibility.rel <= 1.0f))
    return error(ErrorCode::kInvalidArgument, "label fusion: visibility band " + std::to_string(visibility.abs_m) +
                                                  " m + " + std::to_string(visibility.rel) +
                                                  " x depth is out of range (0..10 m, 0..1)");
  return Status::success();
}

std::string LabelFusionOptions::describe() const {
  return "every " + std::to_string(update_every_n_frames) + " frames, working " + std::to_string(working_width) +
         "x" + std::to_string(working_height) + ", cnn " + std::to_string(cnn_width) + "x" +
         std::to_string(cnn_height) + ", visibility band " + std::to_string(visibility.abs_m) + " m + " +
         std::to_string(visibility.rel) + " x depth";
}

Result<LabelFusion> LabelFusion::create(const LabelFusionOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  LabelFusion f;
  f.options_ = options;
  f.observations_.assign(std::size_t(options.cnn_width) * std::size_t(options.cnn_height) * kLabelBytes, 0);
  f.cnn_x_of_index_x_.assign(std::size_t(options.working_width) * kMaxIndexScale, 0);
  f.pairs_.resize(std::size_t(options.working_width) * std::size_t(options.working_height) * kMaxIndexScale *
                  kMaxIndexScale);
  // The memory plan sizes this object by bytes_for(): the two must never disagree.
  if (f.bytes() != bytes_for(options))
    return error(ErrorCode::kInternal, "label fusion: allocated " + std::to_string(f.bytes()) + " bytes, bytes_for() says " +
                                           std::to_string(bytes_for(options)));
  // Builds the observation cost table now (semantic/label_store.cpp), not in the first fuse().
  const float warm[kLabelClasses] = {1.0f};
  uint8_t scratch[kLabelBytes];
  observation_from_probabilities(warm, scratch);
  return f;
}

std::size_t LabelFusion::bytes_for(const LabelFusionOptions& options) {
  const std::size_t working = std::size_t(options.working_width) * std::size_t(options.working_height);
  return std::size_t(options.cnn_width) * std::size_t(options.cnn_height) * kLabelBytes +
         std::size_t(options.working_width) * kMaxIndexScale * sizeof(int32_t) +
         working * kMaxIndexScale * kMaxIndexScale * sizeof(kernels::LabelUpdatePair);
}

Result<LabelFusionCounts> LabelFusion::fuse(const slam::IndexMap& index, const ProbabilityView& cnn,
                                            slam::SurfelPool& pool, ImageView<const float> measured_depth) {
  const ImageView<const float> depth = visible_depth(measured_depth);
  const int scale = index.scale;
  const int W = options_.working_width, H = options_.working_height;
  const int Wc = options_.cnn_width, Hc = options_.cnn_height;
  if (scale < 1 || scale > kMaxIndexScale || index.id.width() != W * scale || index.id.height() != H * scale)
    return error(ErrorCode::kInvalidArgument, "label fusion: the index map does not match the working size");
  if (cnn.data == nullptr || cnn.width != Wc || cnn.height != Hc || cnn.classes != kLabelClasses)
    return error(ErrorCode::kInvalidArgument, "label fusion: the CNN output does not match the options");
  if (!depth.empty() && (depth.width != W || depth.height != H))
    return error(ErrorCode::kInvalidArgument, "label fusion: the depth image is " + std::to_string(depth.width) +
                                                  "x" + std::to_string(depth.height) + ", not the working size " +
                                                  std::to_string(W) + "x" + std::to_string(H));
  if (!depth.empty() && (index.depth.width() != index.id.width() || index.depth.height() != index.id.height()))
    return error(ErrorCode::kInvalidArgument, "label fusion: the index map has no depth of its size");

  // The CNN's side of equation 1, once per CNN pixel.
  for (int y = 0; y < Hc; ++y)
    for (int x = 0; x < Wc; ++x)
      observation_from_probabilities(cnn.pixel(x, y), observations_.data() + (std::size_t(y) * Wc + x) * kLabelBytes);

  const int index_w = W * scale;
  for (int x = 0; x < index_w; ++x) cnn_x_of_index_x_[std::size_t(x)] = nearest(x / scale, W, Wc);

  const int64_t pool_size = pool.size();
  const DepthGate gate = options_.visibility;
  LabelFusionCounts counts;
  std::size_t n = 0;
  for (int y = 0; y < H * scale; ++y) {
    const int32_t* ids = index.id.data() + std::size_t(y) * std::size_t(index_w);
    const float* z_measured = depth.empty() ? nullptr : depth.row(y / scale);
    const float* z_surfel = depth.empty() ? nullptr : index.depth.data() + std::size_t(y) * std::size_t(index_w);
    const int32_t obs_row = nearest(y / scale, H, Hc) * Wc;
    for (int x = 0; x < index_w; ++x) {
      const int32_t id = ids[x];
      if (id < 0) continue;
      if (id >= pool_size)
        return error(ErrorCode::kInvalidArgument, "label fusion: the index map names a surfel outside the pool");
      if (z_measured != nullptr) {
        const float zm = z_measured[x / scale];
        if (!(zm > 0.0f)) {
          ++counts.no_depth_skipped;
          continue;
        }
        if (!gate.accepts(z_surfel[x], zm)) {
          ++counts.hidden_skipped;
          continue;
        }
      }
      pairs_[n++] = kernels::LabelUpdatePair{id, obs_row + cnn_x_of_index_x_[std::size_t(x)]};
    }
  }
  kernels::label_update(pool.labels(), observations_.data(), pairs_.data(), n);
  counts.surfels_updated = static_cast<int64_t>(n);
  return counts;
}

}  // namespace ef::semantic
