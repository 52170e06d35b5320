// Preprocessing of a working-resolution RGB-D frame; see preprocess.h for the conventions.
#include "slam/preprocess.h"

#include "core/stopwatch.h"
#include "kernels/bilateral_row.h"
#include "slam/depth_pyramid.h"
#include "slam/vertex_normal.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>

namespace ef::slam {

namespace {

constexpr int kMaxLevels = 6;
constexpr int kMinCoarsestSize = 8;  // pixels, both dimensions
constexpr float kPi = 3.14159265358979f;

using Clock = SteadyClock;

// Invalid depths are stored as this (metres) in the bilateral filter's padded input: its difference
// to any real depth gives a range weight of exactly 0 (u^8 overflows to infinity).
constexpr float kInvalidDepthSentinel = 1.0e6f;

inline int clamp_index(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

}  // namespace

const opt::Table<PreprocessOptions>& PreprocessOptions::table() {
  static const opt::Table<PreprocessOptions> t = {
      {"depth_cutoff_m", "depth_cutoff_m", "", &PreprocessOptions::depth_cutoff_m, "metres", opt::above(0),
       "depths beyond are ignored"},
  };
  return t;
}

Status PreprocessOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "preprocess options"));
  auto bad = [](const char* what) { return error(ErrorCode::kInvalidArgument, std::string("preprocess options: ") + what); };
  if (levels < 1 || levels > kMaxLevels) return bad("levels must be 1..6");
  if (bilateral_radius_px < 0 || bilateral_radius_px > 8) return bad("bilateral_radius_px must be 0..8");
  if (!(bilateral_sigma_space_px > 0)) return bad("bilateral_sigma_space_px must be > 0");
  // At most 1 m, so that the invalid-depth sentinel still gets a range weight of exactly 0.
  if (!(bilateral_sigma_depth_m > 0 && bilateral_sigma_depth_m <= 1)) return bad("bilateral_sigma_depth_m must be in (0, 1]");
  if (!(pyramid_depth_threshold_m > 0)) return bad("pyramid_depth_threshold_m must be > 0");
  if (!(normal_min_grazing_deg > 0 && normal_min_grazing_deg < 90)) return bad("normal_min_grazing_deg must be in (0, 90)");
  return Status::success();
}

std::string PreprocessOptions::describe() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "levels %d\ndepth_cutoff_m %g m\nbilateral_radius_px %d px\nbilateral_sigma_space_px %g px\n"
                "bilateral_sigma_depth_m %g m\npyramid_depth_threshold_m %g m\nnormal_min_grazing_deg %g deg\n",
                levels, depth_cutoff_m, bilateral_radius_px, bilateral_sigma_space_px, bilateral_sigma_depth_m,
                pyramid_depth_threshold_m, normal_min_grazing_deg);
  return buf;
}

std::size_t Preprocessor::bytes() const {
  const auto b = [](const auto& image) { return image.size() * sizeof(*image.data()); };
  std::size_t total = b(raw_depth_) + b(padded_) + b(spatial_weights_);
  for (int l = 0; l < options_.levels; ++l) {
    const PyramidLevel& p = levels_[l];
    total += b(p.depth) + b(p.vertex) + b(p.normal) + b(p.intensity) + b(p.grad_x) + b(p.grad_y);
  }
  return total;
}

std::size_t Preprocessor::bytes_for(int width, int height, const PreprocessOptions& options) {
  const auto px = [](int w, int h) { return static_cast<std::size_t>(w > 0 ? w : 0) * static_cast<std::size_t>(h > 0 ? h : 0); };
  // Per pixel of every level: depth, vertex, normal, intensity and the two gradients.
  constexpr std::size_t kLevelBytesPerPixel = sizeof(float) + 2 * sizeof(Eigen::Vector3f) + 3 * sizeof(float);
  std::size_t b = 0;
  for (int l = 0, w = width, h = height; l < options.levels; ++l, w /= 2, h /= 2) b += px(w, h) * kLevelBytesPerPixel;
  const int r = options.bilateral_radius_px;
  // Cut depth, padded filter input, spatial weights.
  b += (px(width, height) + px(width + 2 * r, height + 2 * r) + px(2 * r + 1, 2 * r + 1)) * sizeof(float);
  return b;
}

Result<Preprocessor> Preprocessor::create(const Intrinsics& working, const PreprocessOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (!working.valid()) return error(ErrorCode::kInvalidArgument, "preprocess: invalid working intrinsics");
  const Intrinsics coarsest = working.pyramid_level(options.levels - 1);
  if (coarsest.width < kMinCoarsestSize || coarsest.height < kMinCoarsestSize)
    return error(ErrorCode::kInvalidArgument,
                 "preprocess: " + std::to_string(working.width) + "x" + std::to_string(working.height) + " is too small for " +
                     std::to_string(options.levels) + " pyramid levels (coarsest must be at least 8x8)");
  Preprocessor p;
  p.options_ = options;
  for (int l = 0; l < options.levels; ++l) {
    PyramidLevel& lv = p.levels_[l];
    lv.intrinsics = working.pyramid_level(l);
    const int w = lv.intrinsics.width, h = lv.intrinsics.height;
    lv.depth.allocate(w, h);
    lv.vertex.allocate(w, h);
    lv.normal.allocate(w, h);
    lv.intensity.allocate(w, h);
    lv.grad_x.allocate(w, h);
    lv.grad_y.allocate(w, h);
  }
  const int r = options.bilateral_radius_px;
  p.raw_depth_.allocate(working.width, working.height);
  p.padded_.allocate(working.width + 2 * r, working.height + 2 * r);
  p.padded_.fill(kInvalidDepthSentinel);  // the border stays invalid; process() writes the interior
  p.spatial_weights_.allocate(2 * r + 1, 2 * r + 1);
  const float inv_2ss = 1.0f / (2.0f * options.bilateral_sigma_space_px * options.bilateral_sigma_space_px);
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      p.spatial_weights_(dx + r, dy + r) = std::exp(-static_cast<float>(dx * dx + dy * dy) * inv_2ss);
  p.range_scale_ = 1.0f / (2.0f * options.bilateral_sigma_depth_m * options.bilateral_sigma_depth_m);
  return p;
}

ImageView<const float> Preprocessor::raw_depth() const { return raw_depth_.view(); }

Status Preprocessor::process(ImageView<const float> depth, ImageView<const Rgb8> color) {
  const int w = levels_[0].intrinsics.width, h = levels_[0].intrinsics.height;
  if (depth.width != w || depth.height != h)
    return error(ErrorCode::kInvalidArgument, "preprocess: depth is " + std::to_string(depth.width) + "x" +
                                                  std::to_string(depth.height) + ", working size is " + std::to_string(w) +
                                                  "x" + std::to_string(h));
  if (!color.empty() && (color.width != w || color.height != h))
    return error(ErrorCode::kInvalidArgument, "preprocess: colour is " + std::to_string(color.width) + "x" +
                                                  std::to_string(color.height) + ", working size is " + std::to_string(w) +
                                                  "x" + std::to_string(h));
  Clock::time_point t = Clock::now();
  const Clock::time_point start = t;
  cut_off_and_pad(depth);
  bilateral();
  timings_.bilateral_ms = lap_ms(t);
  for (int l = 1; l < options_.levels; ++l)
    downsample_depth(levels_[l - 1].depth, levels_[l].depth, options_.pyramid_depth_threshold_m);
  timings_.depth_pyramid_ms = lap_ms(t);
  for (int l = 0; l < options_.levels; ++l) vertex_normal(l);
  timings_.vertex_normal_ms = lap_ms(t);
  has_intensity_ = !color.empty();
  grey(color);
  for (int l = 1; l < options_.levels; ++l) downsample_intensity(l);
  for (int l = 0; l < options_.levels; ++l) gradients(l);
  timings_.intensity_ms = lap_ms(t);
  timings_.total_ms = std::chrono::duration<double, std::milli>(t - start).count();
  return Status::success();
}

void Preprocessor::cut_off_and_pad(ImageView<const float> depth) {
  const int r = options_.bilateral_radius_px;
  const float cutoff = options_.depth_cutoff_m;
  for (int y = 0; y < depth.height; ++y) {
    const float* src = depth.row(y);
    float* raw = raw_depth_.data() + static_cast<std::size_t>(y) * depth.width;
    float* pad = &padded_(r, y + r);
    // `d > 0 && d <= cutoff` is false for NaN too.
    for (int x = 0; x < depth.width; ++x) raw[x] = (src[x] > 0.0f && src[x] <= cutoff) ? src[x] : 0.0f;
    for (int x = 0; x < depth.width; ++x) pad[x] = raw[x] > 0.0f ? raw[x] : kInvalidDepthSentinel;
  }
}

// KinectFusion's bilateral filter (Newcombe et al. 2011, eq. 2; Tomasi and Manduchi 1998): for a
// valid centre depth d_c, D(u) = sum_q Ns(|u - q|) Nr(d_q - d_c) d_q / sum_q Ns Nr over the valid
// neighbours q of the window; an invalid centre stays invalid (holes are not filled). One row at a
// time by kernels/bilateral_row (SIMD across the pixels of the row: SSE4.1 / AVX2 / AVX-512 / NEON,
// bit-identical to its scalar twin). Invalid pixels and the border of `padded_` hold
// kInvalidDepthSentinel, whose range weight is exactly 0: no masks, no bounds checks.
// The Gaussian range kernel Nr is evaluated as (1 + t/8)^-8, t = (d_q - d_c)^2 / (2 sigma_depth^2).
void Preprocessor::bilateral() {
  const int r = options_.bilateral_radius_px;
  Image<float>& out = levels_[0].depth;
  const int w = out.width(), h = out.height();
  if (r == 0) {
    out.copy_from(raw_depth());
    return;
  }
  const float k8 = range_scale_ * (1.0f / 8.0f);  // u = 1 + t / 8
  const float* rows[2 * 8 + 1];                     // bilateral_radius_px is at most 8
  kernels::BilateralRow row;
  row.rows = rows;
  row.spatial = spatial_weights_.data();
  row.radius = r;
  row.k8 = k8;
  for (int y = 0; y < h; ++y) {
    for (int k = 0; k <= 2 * r; ++k) rows[k] = &padded_(0, y + k);
    row.raw = raw_depth_.data() + static_cast<std::size_t>(y) * w;
    kernels::bilateral_row(row, w, out.data() + static_cast<std::size_t>(y) * w);
  }
}

// The vertex and normal maps of level l (slam/vertex_normal.h).
void Preprocessor::vertex_normal(int l) {
  PyramidLevel& lv = levels_[l];
  const Intrinsics& K = lv.intrinsics;
  // Largest depth step per unit depth between horizontal / vertical neighbours: 1 / (f tan(angle)).
  const float inv_tan = 1.0f / std::tan(options_.normal_min_grazing_deg * (kPi / 180.0f));
  vertex_normal_maps(lv.depth, K, inv_tan / K.fx, inv_tan / K.fy, /*divide=*/false, lv.vertex, lv.normal);
}

void Preprocessor::grey(ImageView<const Rgb8> color) {
  Image<float>& I = levels_[0].intensity;
  if (color.empty()) {
    for (int l = 0; l < options_.levels; ++l) levels_[l].intensity.fill(0.0f);
    return;
  }
  for (int y = 0; y < I.height(); ++y) {
    const Rgb8* c = color.row(y);
    float* o = I.data() + static_cast<std::size_t>(y) * I.width();
    for (int x = 0; x < I.width(); ++x)
      o[x] = grey_level(c[x].r, c[x].g, c[x].b);
  }
}

// Gaussian-like 4x4 binomial [1 3 3 1]/8 (separable) centred on the 2x2 block, then decimation by 2;
// borders replicated.
void Preprocessor::downsample_intensity(int l) {
  if (!has_intensity_) return;  // all zero already
  const Image<float>& src = levels_[l - 1].intensity;
  Image<float>& dst = levels_[l].intensity;
  const int sw = src.width(), sh = src.height();
  static constexpr float kBinomial[4] = {1.0f / 8, 3.0f / 8, 3.0f / 8, 1.0f / 8};
  for (int y = 0; y < dst.height(); ++y) {
    const float* rows[4];
    for (int j = 0; j < 4; ++j) rows[j] = src.data() + static_cast<std::size_t>(clamp_index(2 * y - 1 + j, sh)) * sw;
    for (int x = 0; x < dst.width(); ++x) {
      int xs[4];
      for (int i = 0; i < 4; ++i) xs[i] = clamp_index(2 * x - 1 + i, sw);
      float acc = 0.0f;
      for (int j = 0; j < 4; ++j) {
        const float row = kBinomial[0] * rows[j][xs[0]] + kBinomial[1] * rows[j][xs[1]] + kBinomial[2] * rows[j][xs[2]] +
                          kBinomial[3] * rows[j][xs[3]];
        acc += kBinomial[j] * row;
      }
      dst(x, y) = acc;
    }
  }
}

// Sobel derivative [-1 0 1] x [1 2 1]^T / 8: grey levels per pixel, borders replicated.
void Preprocessor::gradients(int l) {
  PyramidLevel& lv = levels_[l];
  const int w = lv.intensity.width(), h = lv.intensity.height();
  if (!has_intensity_) {
    lv.grad_x.fill(0.0f);
    lv.grad_y.fill(0.0f);
    return;
  }
  const float* I = lv.intensity.data();
  for (int y = 0; y < h; ++y) {
    const float* up = I + static_cast<std::size_t>(clamp_index(y - 1, h)) * w;
    const float* mid = I + static_cast<std::size_t>(y) * w;
    const float* down = I + static_cast<std::size_t>(clamp_index(y + 1, h)) * w;
    float* gx = lv.grad_x.data() + static_cast<std::size_t>(y) * w;
    float* gy = lv.grad_y.data() + static_cast<std::size_t>(y) * w;
    auto sample = [&](int x0, int x, int x1) {
      gx[x] = ((up[x1] + 2.0f * mid[x1] + down[x1]) - (up[x0] + 2.0f * mid[x0] + down[x0])) * 0.125f;
      gy[x] = ((down[x0] + 2.0f * down[x] + down[x1]) - (up[x0] + 2.0f * up[x] + up[x1])) * 0.125f;
    };
    sample(0, 0, w > 1 ? 1 : 0);
    for (int x = 1; x < w - 1; ++x) sample(x - 1, x, x + 1);
    if (w > 1) sample(w - 2, w - 1, w - 1);
  }
}

}  // namespace ef::slam
