// Joint ICP + photometric tracking (see tracker.h for the cost, conventions and references).
#include "slam/tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "kernels/normal_equations.h"
#include "kernels/track_rows.h"
#include "slam/eigenvalues6.h"
#include "slam/preprocess.h"

namespace ef::slam {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
constexpr double kDegToRad = M_PI / 180.0;

bool finite_positive(double v) { return std::isfinite(v) && v > 0; }

using Matrix3d = Eigen::Matrix3d;
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "vertex maps are read as packed xyz floats");

// Pixels per row tile: whole image rows of about this many pixels, so that a tile's rows (2 x 32
// bytes per pixel) stay in the L1/L2 cache between the row kernel and the reduction.
// (Measured on 7-Scenes: tiles of 320 to 8192 pixels all give the same time within 3%.)
constexpr int kTilePixels = 2048;
int tile_image_rows(int width) { return width >= kTilePixels ? 1 : kTilePixels / width; }
// Pixels of the largest tile of a level of this size.
std::size_t tile_pixels(const Intrinsics& k) {
  return static_cast<std::size_t>(std::min(tile_image_rows(k.width), k.height)) * static_cast<std::size_t>(k.width);
}

// H = sum_terms c * (J^T W J), g = sum c * (J^T W r) from upper triangles (kernels::ne_index order).
void accumulate(const double* upper, double c, Matrix6d* H, Vector6d* g) {
  for (int p = 0; p < 6; ++p) {
    for (int q = p; q < 6; ++q) {
      (*H)(p, q) += c * upper[kernels::ne_index(p, q)];
      if (q != p) (*H)(q, p) += c * upper[kernels::ne_index(p, q)];
    }
    (*g)(p) += c * upper[kernels::ne_index(p, 6)];
  }
}

// The factor on the RGB weight for a step whose ICP term has these normal equations (upper
// triangle; see TrackerOptions::rgb_boost_condition): clamp(condition / rgb_boost_condition, 1,
// rgb_boost_max), the largest where the ICP system is singular (no ICP inliers, or a plane).
double rgb_boost_for(const double* icp_upper, const TrackerOptions& o) {
  if (o.rgb_boost_condition <= 0) return 1.0;
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  accumulate(icp_upper, 1.0, &H, &g);
  const Vector6d eigenvalues = symmetric_eigenvalues6(H);
  const double lmin = eigenvalues(0), lmax = eigenvalues(5);
  if (!(lmin > 0)) return o.rgb_boost_max;
  return std::clamp(lmax / lmin / o.rgb_boost_condition, 1.0, o.rgb_boost_max);
}

template <class T>
bool float_strided(const ImageView<const T>& v) {
  return v.stride_bytes % sizeof(float) == 0;
}

bool level_matches(const TrackerLevelView& v, const Intrinsics& k) {
  const auto sized = [&](auto view) { return view.width == k.width && view.height == k.height && !view.empty(); };
  return v.intrinsics.width == k.width && v.intrinsics.height == k.height && v.intrinsics.valid() && sized(v.vertex) &&
         sized(v.normal) && float_strided(v.vertex) && float_strided(v.normal);
}

// The intensity views are usable on this level (same size as the level).
bool has_intensity(const TrackerLevelView& v, bool need_gradients) {
  const auto sized = [&](auto view) {
    return !view.empty() && view.width == v.intrinsics.width && view.height == v.intrinsics.height;
  };
  return sized(v.intensity) && float_strided(v.intensity) &&
         (!need_gradients ||
          (sized(v.grad_x) && sized(v.grad_y) && float_strided(v.grad_x) && float_strided(v.grad_y)));
}

int clamp_index(int i, int n) { return i < 0 ? 0 : i >= n ? n - 1 : i; }

// One pyramid halving of an intensity image as the preprocessor makes it (slam/preprocess.h): a
// coarse pixel is the 4x4 binomial [1 3 3 1] / 8 (separable) of the fine pixels around its 2x2
// block, borders replicated.
void halve_intensity(ImageView<const float> src, Image<float>& dst) {
  static constexpr float kBinomial[4] = {1.0f / 8, 3.0f / 8, 3.0f / 8, 1.0f / 8};
  for (int y = 0; y < dst.height(); ++y) {
    const float* rows[4];
    for (int j = 0; j < 4; ++j) rows[j] = src.row(clamp_index(2 * y - 1 + j, src.height));
    for (int x = 0; x < dst.width(); ++x) {
      int xs[4];
      for (int i = 0; i < 4; ++i) xs[i] = clamp_index(2 * x - 1 + i, src.width);
      float acc = 0.0f;
      for (int j = 0; j < 4; ++j)
        acc += kBinomial[j] * (kBinomial[0] * rows[j][xs[0]] + kBinomial[1] * rows[j][xs[1]] +
                               kBinomial[2] * rows[j][xs[2]] + kBinomial[3] * rows[j][xs[3]]);
      dst(x, y) = acc;
    }
  }
}

// Sobel derivatives [-1 0 1] x [1 2 1]^T / 8 (grey levels per pixel), borders replicated, as the
// preprocessor's.
void sobel_gradients(const Image<float>& I, Image<float>& gx, Image<float>& gy) {
  const int w = I.width(), h = I.height();
  for (int y = 0; y < h; ++y) {
    const int yu = clamp_index(y - 1, h), yd = clamp_index(y + 1, h);
    for (int x = 0; x < w; ++x) {
      const int x0 = clamp_index(x - 1, w), x1 = clamp_index(x + 1, w);
      gx(x, y) = ((I(x1, yu) + 2.0f * I(x1, y) + I(x1, yd)) - (I(x0, yu) + 2.0f * I(x0, y) + I(x0, yd))) * 0.125f;
      gy(x, y) = ((I(x0, yd) + 2.0f * I(x, yd) + I(x1, yd)) - (I(x0, yu) + 2.0f * I(x, yu) + I(x1, yu))) * 0.125f;
    }
  }
}

}  // namespace

PyramidView pyramid_view(const Preprocessor& p) {
  PyramidView view;
  view.levels = p.levels() < kTrackerMaxLevels ? p.levels() : kTrackerMaxLevels;
  for (int l = 0; l < view.levels; ++l) {
    const PyramidLevel& lv = p.level(l);
    TrackerLevelView& v = view.level[l];
    v.intrinsics = lv.intrinsics;
    v.vertex = lv.vertex.view();
    v.normal = lv.normal.view();
    if (p.has_intensity()) {
      v.intensity = lv.intensity.view();
      v.grad_x = lv.grad_x.view();
      v.grad_y = lv.grad_y.view();
    }
  }
  return view;
}

const char* track_lost_reason_name(TrackLostReason r) {
  switch (r) {
    case TrackLostReason::kNone: return "none";
    case TrackLostReason::kNoData: return "no data";
    case TrackLostReason::kTooFewInliers: return "too few inliers";
    case TrackLostReason::kResidualTooLarge: return "residual too large";
    case TrackLostReason::kIllConditioned: return "ill-conditioned";
    case TrackLostReason::kDiverged: return "diverged";
    case TrackLostReason::kInliersDropped: return "inliers dropped";
  }
  return "?";
}

const opt::Table<TrackerOptions>& TrackerOptions::table() {
  static const opt::Table<TrackerOptions> t = {
      {"icp_weight", "icp_weight", "", &TrackerOptions::icp_weight, "", opt::at_least(0),
       "tracking: weight of the ICP term"},
      {"rgb_weight", "rgb_weight", "", &TrackerOptions::rgb_weight, "", opt::at_least(0),
       "tracking: weight of the photometric term"},
      {"rgb_boost_condition", "rgb_boost_condition", "", &TrackerOptions::rgb_boost_condition, "",
       opt::above(1).or_value(0, "off"),
       "tracking: the photometric weight rises where the ICP term's condition number exceeds this"},
      {"rgb_boost_max", "rgb_boost_max", "", &TrackerOptions::rgb_boost_max, "", opt::at_least(1),
       "tracking: the most the photometric weight rises there (a factor on rgb_weight)"},
      {"rgb_min_gradient", "rgb_min_gradient", "", &TrackerOptions::rgb_min_gradient_grey, "grey levels/pixel",
       opt::between(0, 255), "tracking: a photometric row needs the predicted image's gradient at least this"},
      {"rgb_gain", "rgb_gain", "", &TrackerOptions::rgb_gain, "", opt::any(),
       "tracking: compare intensities through a fitted exposure and vignetting gain"},
      {"lost_max_condition", "lost_max_condition", "", &TrackerOptions::lost_max_condition, "", opt::at_least(1),
       "tracking: a frame is lost when its system's condition number (largest / smallest eigenvalue) exceeds "
       "this: a direction the data does not see"},
      {"lost_min_inlier_fraction", "", "", &TrackerOptions::lost_min_inlier_fraction, "fraction", opt::between(0, 1),
       "tracking: a frame is lost when fewer of its valid pixels than this are ICP inliers at the final pose (0.79 "
       "on 7-Scenes at the right pose, 0.15-0.20 on noisy synthetic frames, 0.02 against another room)"},
      {"lost_min_inliers", "", "", &TrackerOptions::lost_min_inliers, "pixels", opt::at_least(0),
       "tracking: ... or fewer inliers than this at all (level 0)"},
      {"lost_max_icp_rms_m", "", "", &TrackerOptions::lost_max_icp_rms_m, "metres", opt::above(0),
       "tracking: a frame is lost when the RMS of its ICP inlier residuals exceeds this"},
      {"lost_max_rgb_rms_grey", "", "", &TrackerOptions::lost_max_rgb_rms_grey, "grey levels", opt::above(0),
       "tracking: the same for the photometric residuals when only colour tracks (icp_weight 0)"},
      {"lost_max_correction_m", "", "", &TrackerOptions::lost_max_correction_m, "metres", opt::above(0),
       "tracking: a frame is lost (diverged) when tracking moves the camera further than this from its guess"},
      {"lost_max_correction_deg", "", "", &TrackerOptions::lost_max_correction_deg, "degrees", opt::above(0),
       "tracking: ... or turns it more than this"},
  };
  return t;
}

Status TrackerOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "tracker"));
  const auto bad = [](const char* field) {
    return error(ErrorCode::kInvalidArgument, std::string("TrackerOptions.") + field + " out of range");
  };
  for (int it : iterations)
    if (it < 0 || it > 100) return bad("iterations");
  if (!(stop_translation_m >= 0) || !(stop_rotation_rad >= 0)) return bad("stop_translation_m/stop_rotation_rad");
  if (so3_iterations < 0 || so3_iterations > 100) return bad("so3_iterations");
  if (so3_level < -1 || so3_level > kTrackerMaxLevels) return bad("so3_level");
  if (icp_weight == 0 && rgb_weight == 0)
    return error(ErrorCode::kInvalidArgument, "tracker: icp_weight and rgb_weight are both 0 (nothing to track with)");
  if (!finite_positive(icp_sigma_m)) return bad("icp_sigma_m");
  if (!(icp_depth_weight_ref_m > 0.4f && icp_depth_weight_ref_m < 100.0f)) return bad("icp_depth_weight_ref_m");
  if (!finite_positive(icp_max_distance_m)) return bad("icp_max_distance_m");
  if (!(icp_max_normal_angle_deg > 0 && icp_max_normal_angle_deg <= 90)) return bad("icp_max_normal_angle_deg");
  if (!finite_positive(rgb_sigma_grey)) return bad("rgb_sigma_grey");
  if (!finite_positive(rgb_huber_k)) return bad("rgb_huber_k");
  if (!finite_positive(rgb_max_depth_diff_m)) return bad("rgb_max_depth_diff_m");
  if (!finite_positive(rgb_max_depth_m)) return bad("rgb_max_depth_m");
  return Status::success();
}

std::string TrackerOptions::describe() const {
  std::ostringstream s;
  s << "iterations (per level, fine to coarse)";
  for (int it : iterations) s << ' ' << it;
  s << "\nstop_translation_m " << stop_translation_m << " m\nstop_rotation_rad " << stop_rotation_rad << " rad"
    << "\nso3_prealign " << (so3_prealign ? "on" : "off") << "\nso3_iterations " << so3_iterations
    << "\nso3_level " << so3_level << (so3_level < 0 ? " (one halving below the coarsest level)" : "")
    << "\nicp_weight " << icp_weight << "\nicp_sigma_m " << icp_sigma_m << " m\nicp_depth_weighting "
    << (icp_depth_weighting ? "on" : "off") << "\nicp_depth_weight_ref_m " << icp_depth_weight_ref_m
    << " m\nicp_max_distance_m "
    << icp_max_distance_m << " m\nicp_max_normal_angle_deg " << icp_max_normal_angle_deg << " deg\nrgb_weight "
    << rgb_weight << "\nrgb_boost_condition " << rgb_boost_condition << (rgb_boost_condition > 0 ? "" : " (off)")
    << "\nrgb_boost_max " << rgb_boost_max << "\nrgb_sigma_grey " << rgb_sigma_grey << " grey levels\nrgb_huber_k "
    << rgb_huber_k
    << " sigma\nrgb_min_gradient_grey " << rgb_min_gradient_grey << " grey levels/pixel\nrgb_gain " << (rgb_gain ? "on" : "off")
    << "\nrgb_max_depth_diff_m " << rgb_max_depth_diff_m << " m\nrgb_max_depth_m " << rgb_max_depth_m
    << " m\nlost_min_inlier_fraction " << lost_min_inlier_fraction << "\nlost_min_inliers " << lost_min_inliers
    << " px\nlost_max_icp_rms_m " << lost_max_icp_rms_m << " m\nlost_max_rgb_rms_grey " << lost_max_rgb_rms_grey
    << " grey levels\nlost_max_condition " << lost_max_condition << "\nlost_max_correction_m "
    << lost_max_correction_m << " m\nlost_max_correction_deg " << lost_max_correction_deg << " deg\n";
  return s.str();
}

namespace {

// The SO(3) level needs at least this size (pixels) to be the tracker's own extra halving.
constexpr int kSo3MinWidth = 16, kSo3MinHeight = 12;

// What create() allocates for a pyramid with this level 0, written once for create() and bytes_for().
struct TrackerLayout {
  Intrinsics extra;       // the halving below the coarsest level
  bool extra_ok = false;  // large enough for the SO(3) alignment
  int so3_level = 0;      // options.so3_level resolved (levels = the extra level)
  std::size_t tile_capacity = 0;  // pixels per row tile: the largest over every level linearised
};

TrackerLayout tracker_layout(const Intrinsics& level0, int levels, const TrackerOptions& options) {
  TrackerLayout t;
  t.extra = level0.pyramid_level(levels);
  t.extra_ok = t.extra.width >= kSo3MinWidth && t.extra.height >= kSo3MinHeight;
  t.so3_level = options.so3_level >= 0 ? options.so3_level : t.extra_ok ? levels : levels - 1;
  // Every level linearise() runs on: the pyramid's and the SO(3) one.
  for (int l = 0; l <= levels; ++l)
    if (l < levels || t.so3_level == levels)
      t.tile_capacity = std::max(t.tile_capacity, tile_pixels(level0.pyramid_level(l)));
  return t;
}

// Bytes of the allocations for a layout: the tile (2 x 8 floats per pixel), the four images of the
// extra SO(3) level (when used) and the rays (3 floats per pixel of the SO(3) level).
std::size_t tracker_bytes(const TrackerLayout& t, const Intrinsics& level0, int levels) {
  const Intrinsics ks = level0.pyramid_level(t.so3_level);
  const std::size_t extra_pixels = static_cast<std::size_t>(t.extra.width) * t.extra.height;
  const std::size_t so3_images = t.so3_level == levels ? 4 * extra_pixels : 0;
  const std::size_t rays = 3 * static_cast<std::size_t>(ks.width) * ks.height;
  const std::size_t gain_row = static_cast<std::size_t>(level0.width);  // the widest level's row
  return (2 * kernels::kNeComponents * t.tile_capacity + so3_images + rays + gain_row) * sizeof(float);
}

}  // namespace

std::size_t Tracker::bytes_for(int width, int height, int levels, const TrackerOptions& options) {
  // Only the sizes matter here: pyramid_level() halves width and height whatever the focal lengths.
  const Intrinsics level0{1.0f, 1.0f, 0.0f, 0.0f, width, height};
  return tracker_bytes(tracker_layout(level0, levels, options), level0, levels);
}

std::size_t Tracker::bytes() const {
  // Counted from what this tracker holds, independently of the layout above.
  const Intrinsics ks = level0_.pyramid_level(so3_level_);
  std::size_t floats = 2 * kernels::kNeComponents * tile_capacity_ + 3 * static_cast<std::size_t>(ks.width) * ks.height;
  floats += static_cast<std::size_t>(level0_.width);  // gain_row_
  for (const Image<float>* im : {&so3_ref_intensity_, &so3_ref_grad_x_, &so3_ref_grad_y_, &so3_cur_intensity_})
    floats += static_cast<std::size_t>(im->width()) * im->height();
  return floats * sizeof(float);
}

Result<Tracker> Tracker::create(const Intrinsics& level0, int levels, const TrackerOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (!level0.valid()) return error(ErrorCode::kInvalidArgument, "Tracker: invalid intrinsics");
  if (levels < 1 || levels > kTrackerMaxLevels)
    return error(ErrorCode::kInvalidArgument, "Tracker: levels must be 1.." + std::to_string(kTrackerMaxLevels));
  const Intrinsics coarsest = level0.pyramid_level(levels - 1);
  if (coarsest.width < 8 || coarsest.height < 8)
    return error(ErrorCode::kInvalidArgument, "Tracker: coarsest level smaller than 8x8");
  if (options.so3_level > levels)
    return error(ErrorCode::kInvalidArgument, "Tracker: so3_level beyond the pyramid's levels + 1");
  const TrackerLayout layout = tracker_layout(level0, levels, options);
  if (options.so3_level == levels && !layout.extra_ok)
    return error(ErrorCode::kInvalidArgument, "Tracker: so3_level " + std::to_string(levels) + " would be smaller than " +
                                                  std::to_string(kSo3MinWidth) + "x" + std::to_string(kSo3MinHeight));
  Tracker t;
  t.options_ = options;
  t.level0_ = level0;
  t.levels_ = levels;
  t.so3_level_ = layout.so3_level;
  if (t.so3_level_ == levels) {
    const Intrinsics& extra = layout.extra;
    t.so3_ref_intensity_.allocate(extra.width, extra.height);
    t.so3_ref_grad_x_.allocate(extra.width, extra.height);
    t.so3_ref_grad_y_.allocate(extra.width, extra.height);
    t.so3_cur_intensity_.allocate(extra.width, extra.height);
  }
  t.tile_capacity_ = layout.tile_capacity;
  t.tile_.reset(new float[2 * kernels::kNeComponents * t.tile_capacity_]());
  t.gain_row_.reset(new float[static_cast<std::size_t>(level0.width)]());
  // Rays K^-1 (x, y, 1) of the SO(3) level: the "vertices" of the rotation-only alignment.
  const Intrinsics ks = level0.pyramid_level(t.so3_level_);
  t.rays_.reset(new float[3 * static_cast<std::size_t>(ks.width) * ks.height]);
  for (int y = 0; y < ks.height; ++y)
    for (int x = 0; x < ks.width; ++x) {
      float* r = t.rays_.get() + 3 * (static_cast<std::size_t>(y) * ks.width + x);
      r[0] = (static_cast<float>(x) - ks.cx) / ks.fx;
      r[1] = (static_cast<float>(y) - ks.cy) / ks.fy;
      r[2] = 1.0f;
    }
  return t;
}

// Row component holding the weight w (kernels/normal_equations.h: J0..J5, r, w).
constexpr int kWeightComponent = kernels::kNeComponents - 1;

// Multiplies the weights of n ICP rows by (sigma(z_ref) / sigma(z))^2, capped at 4
// (TrackerOptions::icp_depth_weighting); vertex: n current points, xyz. Rows without an inlier have
// weight 0 and stay 0. Returns the sum of the new weights (the inliers' factors).
float Tracker::weight_icp_rows_by_depth(const float* vertex, std::size_t n, float* weights) const {
  const auto sigma = [](float z) {
    const float d = z - 0.4f;
    return 0.0012f + 0.0019f * d * d;
  };
  const float s_ref = sigma(options_.icp_depth_weight_ref_m);
  float sum = 0.0f;
  for (std::size_t j = 0; j < n; ++j) {
    const float r = s_ref / sigma(vertex[3 * j + 2]);
    weights[j] *= std::min(r * r, 4.0f);
    sum += weights[j];
  }
  return sum;
}

void Tracker::fit_gain(const TrackerLevelView& cur, int y0, int y1, const PhotoGain& gain, const float* residuals,
                       const float* weights, Linearisation* out) const {
  const Intrinsics& k = cur.intrinsics;
  const double inv_r2 = 1.0 / (static_cast<double>(k.cx) * k.cx + static_cast<double>(k.cy) * k.cy);
  double ss0 = 0, ss1 = 0, ss2 = 0, sb0 = 0, sb1 = 0;
  for (int y = y0; y < y1; ++y) {
    const std::size_t off = static_cast<std::size_t>(y - y0) * k.width;
    const float* c = cur.intensity.row(y);
    const double dy = y - static_cast<double>(k.cy);
    for (int x = 0; x < k.width; ++x) {
      const double w = weights[off + x];
      if (!(w > 0.0)) continue;  // no photometric row
      const double dx = x - static_cast<double>(k.cx);
      const double rho = (dx * dx + dy * dy) * inv_r2;
      const double ci = c[x];
      // The kernel's r = B(I_ref) - gain c, so B(I_ref) = r + gain c.
      const double ref = residuals[off + x] + (gain.a0 + gain.a2 * rho) * ci;
      const double wc = w * ci;
      ss0 += wc * ci;
      ss1 += wc * ci * rho;
      ss2 += wc * ci * rho * rho;
      sb0 += wc * ref;
      sb1 += wc * ref * rho;
    }
  }
  out->ss[0] += ss0;
  out->ss[1] += ss1;
  out->ss[2] += ss2;
  out->sb[0] += sb0;
  out->sb[1] += sb1;
}

void Tracker::PhotoGain::refit(const Linearisation& lin) {
  // Too few rows to trust a fit: keep the gain. Bounds: what exposure and vignetting can do
  // between two views (TrackerOptions::rgb_gain); a fit outside them is a misalignment, not a gain.
  if (lin.rgb_inliers < 64 || !(lin.ss[0] > 0)) return;
  const double det = lin.ss[0] * lin.ss[2] - lin.ss[1] * lin.ss[1];
  double b0 = lin.sb[0] / lin.ss[0], b2 = 0;  // without radial spread: the gain alone
  if (det > 1e-9 * lin.ss[0] * lin.ss[2]) {
    b0 = (lin.sb[0] * lin.ss[2] - lin.sb[1] * lin.ss[1]) / det;
    b2 = (lin.ss[0] * lin.sb[1] - lin.ss[1] * lin.sb[0]) / det;
  }
  if (!std::isfinite(b0) || !std::isfinite(b2)) return;
  a0 = std::clamp(b0, 0.25, 4.0);
  a2 = std::clamp(b2, -1.0, 1.0);
}

void Tracker::linearise(const TrackerLevelView& ref, const TrackerLevelView& cur, const Eigen::Matrix3f& R,
                        const Eigen::Vector3f& t, bool use_icp, bool use_rgb, const float* rays,
                        const PhotoGain* gain, bool fit, Linearisation* out) {
  static_assert(kNeUpper == kernels::kNeOutputs, "Linearisation holds NormalEquations::upper");
  *out = Linearisation{};
  const Intrinsics& k = ref.intrinsics;  // the reference camera: where current points are projected
  kernels::TrackRowsParams P;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P.R[3 * r + c] = R(r, c);
    P.t[r] = t(r);
  }
  P.fx = k.fx;
  P.fy = k.fy;
  P.cx = k.cx;
  P.cy = k.cy;
  P.width = k.width;
  P.height = k.height;
  const auto floats = [](const auto& view) { return reinterpret_cast<const float*>(view.data); };
  const auto stride = [](const auto& view) { return static_cast<std::ptrdiff_t>(view.stride_bytes / sizeof(float)); };
  P.ref_vertex = floats(ref.vertex);
  P.ref_normal = floats(ref.normal);
  P.vertex_stride = stride(ref.vertex);
  P.normal_stride = stride(ref.normal);
  if (use_rgb) {
    P.ref_intensity = ref.intensity.data;
    P.ref_grad_x = ref.grad_x.data;
    P.ref_grad_y = ref.grad_y.data;
    P.intensity_stride = stride(ref.intensity);
    P.grad_x_stride = stride(ref.grad_x);
    P.grad_y_stride = stride(ref.grad_y);
  }
  P.icp_max_d2 = options_.icp_max_distance_m * options_.icp_max_distance_m;
  const float sin_gate = static_cast<float>(std::sin(options_.icp_max_normal_angle_deg * kDegToRad));
  P.icp_sin2_max = sin_gate * sin_gate;
  P.rgb_huber_grey = static_cast<float>(options_.rgb_huber_k * options_.rgb_sigma_grey);
  P.rgb_max_depth_diff = options_.rgb_max_depth_diff_m;
  P.rgb_max_depth = options_.rgb_max_depth_m;
  P.rgb_min_grad2 = static_cast<float>(options_.rgb_min_gradient_grey * options_.rgb_min_gradient_grey);
  P.use_icp = use_icp;
  P.use_rgb = use_rgb;
  P.rgb_depth_gate = rays == nullptr;

  const int w = cur.intrinsics.width, h = cur.intrinsics.height;
  const int rows_per_tile = tile_image_rows(w);
  // Photometric gain: identity until a fit moves it (then the rows are exactly those without it).
  const bool scale = use_rgb && gain != nullptr && (gain->a0 != 1.0 || gain->a2 != 0.0);
  const bool fit_rows = use_rgb && gain != nullptr && fit;
  const Intrinsics& kc = cur.intrinsics;  // rho is about the current image's principal point
  const float a2 = gain != nullptr ? static_cast<float>(gain->a2 / (static_cast<double>(kc.cx) * kc.cx +
                                                                     static_cast<double>(kc.cy) * kc.cy))
                                   : 0.0f;  // per squared pixel
  const std::size_t cap = tile_capacity_;
  float* icp_tile = tile_.get();
  float* rgb_tile = tile_.get() + kernels::kNeComponents * cap;
  kernels::TrackRowsCounts counts;
  kernels::NormalEquations ne;
  const bool depth_weighting = use_icp && rays == nullptr && options_.icp_depth_weighting;
  double icp_weight_sum = 0.0;
  for (int y0 = 0; y0 < h; y0 += rows_per_tile) {
    const int y1 = std::min(h, y0 + rows_per_tile);
    const int64_t icp_before = counts.icp, rgb_before = counts.rgb;
    for (int y = y0; y < y1; ++y) {
      const std::size_t off = static_cast<std::size_t>(y - y0) * w;
      const float* vertex = rays != nullptr ? rays + 3 * static_cast<std::size_t>(y) * w
                                            : reinterpret_cast<const float*>(cur.vertex.row(y));
      const float* intensity = use_rgb ? cur.intensity.row(y) : nullptr;
      if (scale) {  // the current row through the gain (PhotoGain): w multiplies, no allocation
        const float dy = static_cast<float>(y) - kc.cy;
        const float row = static_cast<float>(gain->a0) + a2 * (dy * dy);
        float* g = gain_row_.get();
        for (int x = 0; x < w; ++x) {
          const float dx = static_cast<float>(x) - kc.cx;
          g[x] = intensity[x] * (row + a2 * (dx * dx));
        }
        intensity = g;
      }
      kernels::track_rows(P, vertex, use_icp ? reinterpret_cast<const float*>(cur.normal.row(y)) : nullptr,
                          intensity, static_cast<std::size_t>(w),
                          use_icp ? icp_tile + off : nullptr, use_rgb ? rgb_tile + off : nullptr, cap, &counts);
      if (depth_weighting)
        icp_weight_sum += weight_icp_rows_by_depth(vertex, static_cast<std::size_t>(w), icp_tile + kWeightComponent * cap + off);
    }
    if (fit_rows && counts.rgb > rgb_before)
      fit_gain(cur, y0, y1, *gain, rgb_tile + (kWeightComponent - 1) * cap, rgb_tile + kWeightComponent * cap, out);
    // A tile without inliers in a term is all zeros there: it would add exactly nothing.
    const std::size_t n = static_cast<std::size_t>(y1 - y0) * w;
    if (use_icp && counts.icp > icp_before) {
      kernels::reduce_normal_equations(icp_tile, cap, n, &ne);
      for (int o = 0; o < kNeUpper; ++o) out->icp[o] += ne.upper[o];
    }
    if (use_rgb && counts.rgb > rgb_before) {
      kernels::reduce_normal_equations(rgb_tile, cap, n, &ne);
      for (int o = 0; o < kNeUpper; ++o) out->rgb[o] += ne.upper[o];
    }
  }
  // Depth weights only re-balance the points among themselves: rescaled to a mean of 1 per inlier,
  // so the ICP term keeps its weight against the photometric one whatever the scene's depth.
  if (depth_weighting && icp_weight_sum > 0.0) {
    const double mean_one = static_cast<double>(counts.icp) / icp_weight_sum;
    for (int o = 0; o < kNeUpper; ++o) out->icp[o] *= mean_one;
  }
  out->valid = counts.valid;
  out->icp_inliers = counts.icp;
  out->rgb_inliers = counts.rgb;
}

Matrix3d Tracker::prealign_rotation(const TrackerLevelView& ref, const TrackerLevelView& cur, const Matrix3d& R0,
                                    PhotoGain* gain, TrackResult* res) {
  Matrix3d R = R0;
  Linearisation lin;
  const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
  double first_cost = -1, cost = 0;
  for (int it = 0; it <= options_.so3_iterations; ++it) {
    linearise(ref, cur, R.cast<float>(), zero, false, true, rays_.get(), gain, true, &lin);
    if (lin.rgb_inliers < 3) return R0;
    if (gain != nullptr) gain->refit(lin);
    // Mean robust cost of this rotation (sum w r^2 / pixels with a row): IRLS Huber weights make
    // w r^2 the Huber cost up to a constant per outlier.
    cost = lin.rgb[kernels::ne_index(6, 6)] / static_cast<double>(lin.rgb_inliers);
    if (first_cost < 0) first_cost = cost;
    if (it == options_.so3_iterations) break;  // the last pass only measures the cost
    Eigen::Matrix3d H;
    Eigen::Vector3d g;
    for (int p = 0; p < 3; ++p) {
      for (int q = 0; q < 3; ++q)
        H(p, q) = lin.rgb[p <= q ? kernels::ne_index(3 + p, 3 + q) : kernels::ne_index(3 + q, 3 + p)];
      g(p) = lin.rgb[kernels::ne_index(3 + p, 6)];
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    const Eigen::Vector3d w = ldlt.solve(-g);
    if (!w.allFinite()) return R0;
    Vector6d xi = Vector6d::Zero();
    xi.tail<3>() = w;
    R = SE3::exp(xi).rotation_matrix() * R;
    ++res->so3_iterations;
    if (w.norm() < options_.stop_rotation_rad) {
      // Converged: the cost at the new rotation is the one just measured, to within the step.
      break;
    }
  }
  if (!(cost < first_cost)) return R0;
  res->so3_applied = true;
  res->so3_rotation_deg = Eigen::AngleAxisd(R * R0.transpose()).angle() / kDegToRad;
  return R;
}

Status Tracker::track(const PyramidView& reference, const PyramidView& current, const SE3& T_ref_cur_guess,
                      TrackResult* result) {
  if (result == nullptr) return error(ErrorCode::kInvalidArgument, "Tracker::track: null result");
  if (reference.levels < levels_ || current.levels < levels_)
    return error(ErrorCode::kInvalidArgument, "Tracker::track: pyramid has fewer levels than the tracker");
  bool rgb_level[kTrackerMaxLevels] = {};
  const bool icp_on = options_.icp_weight > 0;
  for (int l = 0; l < levels_; ++l) {
    const Intrinsics k = level0_.pyramid_level(l);
    if (!level_matches(reference.level[l], k) || !level_matches(current.level[l], k))
      return error(ErrorCode::kInvalidArgument, "Tracker::track: level " + std::to_string(l) + " size mismatch");
    rgb_level[l] = options_.rgb_weight > 0 && has_intensity(reference.level[l], true) &&
                   has_intensity(current.level[l], false);
  }

  TrackResult& res = *result;
  res = TrackResult{};
  const double c_icp = options_.icp_weight / (options_.icp_sigma_m * options_.icp_sigma_m);
  const double c_rgb = options_.rgb_weight / (options_.rgb_sigma_grey * options_.rgb_sigma_grey);
  SE3 T = T_ref_cur_guess;
  bool diverged = false;

  PhotoGain gain;
  const bool gain_on = options_.rgb_gain;

  // SO(3) pre-alignment on its level (needs intensity in both frames there).
  const int ls = std::min(so3_level_, levels_ - 1);
  if (options_.so3_prealign && options_.so3_iterations > 0 && has_intensity(reference.level[ls], true) &&
      has_intensity(current.level[ls], false) && T.translation().allFinite()) {
    TrackerLevelView ref = reference.level[ls], cur = current.level[ls];
    if (so3_level_ == levels_) {  // the extra halving, made here
      halve_intensity(ref.intensity, so3_ref_intensity_);
      sobel_gradients(so3_ref_intensity_, so3_ref_grad_x_, so3_ref_grad_y_);
      halve_intensity(cur.intensity, so3_cur_intensity_);
      ref = TrackerLevelView{};
      ref.intrinsics = level0_.pyramid_level(levels_);
      ref.intensity = so3_ref_intensity_.view();
      ref.grad_x = so3_ref_grad_x_.view();
      ref.grad_y = so3_ref_grad_y_.view();
      cur = TrackerLevelView{};
      cur.intrinsics = ref.intrinsics;
      cur.intensity = so3_cur_intensity_.view();
    }
    const Matrix3d R = prealign_rotation(ref, cur, T.rotation_matrix(), gain_on ? &gain : nullptr, &res);
    if (res.so3_applied) T = SE3(R, T.translation());
  }

  // Linearises level l at pose T into H and g (normalised and weighted); fills lin.
  Linearisation lin;
  double rgb_boost = 1.0;  // of the last linearisation
  const auto linearise_at = [&](int l, Matrix6d* H, Vector6d* g) {
    linearise(reference.level[l], current.level[l], T.rotation_matrix().cast<float>(), T.translation().cast<float>(),
              icp_on, rgb_level[l], nullptr, gain_on ? &gain : nullptr, l > 0, &lin);
    if (gain_on && rgb_level[l] && l > 0) gain.refit(lin);
    H->setZero();
    g->setZero();
    if (icp_on) accumulate(lin.icp, c_icp, H, g);
    rgb_boost = icp_on && rgb_level[l] ? rgb_boost_for(lin.icp, options_) : 1.0;
    if (rgb_level[l]) accumulate(lin.rgb, c_rgb * rgb_boost, H, g);
  };

  Matrix6d H;
  Vector6d g;
  // Whether H, g and lin hold level 0 within the stop thresholds of the final pose.
  bool final_linearised = false;
  for (int l = levels_ - 1; l >= 0 && !diverged; --l) {
    for (int it = 0; it < options_.iterations[l]; ++it) {
      final_linearised = false;
      linearise_at(l, &H, &g);
      if (lin.icp_inliers + lin.rgb_inliers < 6) break;  // nothing to solve on this level
      const Eigen::LDLT<Matrix6d> ldlt(H);
      if (ldlt.info() != Eigen::Success) break;
      const Vector6d xi = ldlt.solve(-g);
      if (!xi.allFinite()) {
        diverged = true;
        break;
      }
      T = SE3::exp(xi) * T;
      ++res.iterations;
      ++res.level_iterations[l];
      if (xi.head<3>().norm() < options_.stop_translation_m && xi.tail<3>().norm() < options_.stop_rotation_rad) {
        final_linearised = l == 0;
        break;
      }
    }
  }

  // Quality at the final pose, level 0 (see tracker.h: a converged last step reuses its linearisation).
  if (!final_linearised) linearise_at(0, &H, &g);
  res.T_ref_cur = T;
  res.valid_current = lin.valid;
  res.icp_inliers = lin.icp_inliers;
  res.rgb_inliers = lin.rgb_inliers;
  res.rgb_boost = rgb_boost;
  res.gain_a0 = gain.a0;
  res.gain_a2 = gain.a2;
  const int r2 = kernels::ne_index(6, 6);
  res.icp_rms_m = lin.icp_inliers > 0 ? std::sqrt(lin.icp[r2] / static_cast<double>(lin.icp_inliers)) : 0.0;
  res.rgb_rms_grey = lin.rgb_inliers > 0 ? std::sqrt(lin.rgb[r2] / static_cast<double>(lin.rgb_inliers)) : 0.0;
  const int64_t judged = icp_on ? lin.icp_inliers : lin.rgb_inliers;
  res.inlier_fraction = lin.valid > 0 ? static_cast<double>(judged) / static_cast<double>(lin.valid) : 0.0;
  const Vector6d eigenvalues = symmetric_eigenvalues6(H);
  const double lmin = eigenvalues(0), lmax = eigenvalues(5);
  res.min_eigenvalue = lmin;
  res.condition = lmin > 0 ? lmax / lmin : std::numeric_limits<double>::infinity();

  const SE3 correction = T * T_ref_cur_guess.inverse();
  const bool correction_ok = correction.translation().norm() <= options_.lost_max_correction_m &&
                             correction.angle() <= options_.lost_max_correction_deg * kDegToRad;
  const bool rms_ok = icp_on ? res.icp_rms_m <= options_.lost_max_icp_rms_m
                             : res.rgb_rms_grey <= options_.lost_max_rgb_rms_grey;
  TrackLostReason reason = TrackLostReason::kNone;
  if (lin.valid == 0 || (!icp_on && !rgb_level[0]))
    reason = TrackLostReason::kNoData;
  else if (diverged || !T.translation().allFinite() || !correction_ok)
    reason = TrackLostReason::kDiverged;
  else if (judged < options_.lost_min_inliers || res.inlier_fraction < options_.lost_min_inlier_fraction)
    reason = TrackLostReason::kTooFewInliers;
  else if (!rms_ok)
    reason = TrackLostReason::kResidualTooLarge;
  else if (!(res.condition <= options_.lost_max_condition))
    reason = TrackLostReason::kIllConditioned;
  res.reason = reason;
  res.lost = reason != TrackLostReason::kNone;
  return Status::success();
}

}  // namespace ef::slam
