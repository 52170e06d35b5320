// Joint ICP + photometric tracking (see tracker.h for the cost, conventions and references).
#include "slam/tracker.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "kernels/normal_equations.h"
#include "slam/preprocess.h"

namespace ef::slam {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
constexpr double kDegToRad = M_PI / 180.0;

bool finite_positive(double v) { return std::isfinite(v) && v > 0; }

// Writes one SoA row (kernels/normal_equations.h layout) at index i of a level with stride n.
inline void put_row(float* rows, std::size_t n, std::size_t i, const Eigen::Vector3f& jv, const Eigen::Vector3f& jw,
                    float r, float w) {
  rows[0 * n + i] = jv.x();
  rows[1 * n + i] = jv.y();
  rows[2 * n + i] = jv.z();
  rows[3 * n + i] = jw.x();
  rows[4 * n + i] = jw.y();
  rows[5 * n + i] = jw.z();
  rows[6 * n + i] = r;
  rows[7 * n + i] = w;
}

inline void put_zero_row(float* rows, std::size_t n, std::size_t i) {
  for (int k = 0; k < kernels::kNeComponents; ++k) rows[k * n + i] = 0.0f;
}

// Adds c * (J^T W J) and c * (J^T W r) of `ne` into H and g.
void accumulate(const kernels::NormalEquations& ne, double c, Matrix6d* H, Vector6d* g) {
  for (int p = 0; p < 6; ++p) {
    for (int q = 0; q < 6; ++q) (*H)(p, q) += c * ne.jtj(p, q);
    (*g)(p) += c * ne.jtr(p);
  }
}

bool level_matches(const TrackerLevelView& v, const Intrinsics& k) {
  const auto sized = [&](auto view) { return view.width == k.width && view.height == k.height && !view.empty(); };
  return v.intrinsics.width == k.width && v.intrinsics.height == k.height && v.intrinsics.valid() && sized(v.vertex) &&
         sized(v.normal);
}

// The intensity views are usable on this level (same size as the level).
bool has_intensity(const TrackerLevelView& v, bool need_gradients) {
  const auto sized = [&](auto view) {
    return !view.empty() && view.width == v.intrinsics.width && view.height == v.intrinsics.height;
  };
  return sized(v.intensity) && (!need_gradients || (sized(v.grad_x) && sized(v.grad_y)));
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
  }
  return "?";
}

Status TrackerOptions::validate() const {
  const auto bad = [](const char* field) {
    return error(ErrorCode::kInvalidArgument, std::string("TrackerOptions.") + field + " out of range");
  };
  for (int it : iterations)
    if (it < 0 || it > 100) return bad("iterations");
  if (!(stop_translation_m >= 0) || !(stop_rotation_rad >= 0)) return bad("stop_translation_m/stop_rotation_rad");
  if (!(icp_weight >= 0) || !std::isfinite(icp_weight)) return bad("icp_weight");
  if (!(rgb_weight >= 0) || !std::isfinite(rgb_weight)) return bad("rgb_weight");
  if (icp_weight == 0 && rgb_weight == 0) return bad("icp_weight and rgb_weight (both 0)");
  if (!finite_positive(icp_sigma_m)) return bad("icp_sigma_m");
  if (!finite_positive(icp_max_distance_m)) return bad("icp_max_distance_m");
  if (!(icp_max_normal_angle_deg > 0 && icp_max_normal_angle_deg <= 90)) return bad("icp_max_normal_angle_deg");
  if (!finite_positive(rgb_sigma_grey)) return bad("rgb_sigma_grey");
  if (!finite_positive(rgb_huber_k)) return bad("rgb_huber_k");
  if (!finite_positive(rgb_max_depth_diff_m)) return bad("rgb_max_depth_diff_m");
  if (!finite_positive(rgb_max_depth_m)) return bad("rgb_max_depth_m");
  if (!(lost_min_inlier_fraction >= 0 && lost_min_inlier_fraction <= 1)) return bad("lost_min_inlier_fraction");
  if (lost_min_inliers < 0) return bad("lost_min_inliers");
  if (!finite_positive(lost_max_icp_rms_m)) return bad("lost_max_icp_rms_m");
  if (!finite_positive(lost_max_rgb_rms_grey)) return bad("lost_max_rgb_rms_grey");
  if (!(lost_max_condition >= 1)) return bad("lost_max_condition");
  if (!finite_positive(lost_max_correction_m)) return bad("lost_max_correction_m");
  if (!finite_positive(lost_max_correction_deg)) return bad("lost_max_correction_deg");
  return Status::success();
}

std::string TrackerOptions::describe() const {
  std::ostringstream s;
  s << "iterations (per level, fine to coarse)";
  for (int it : iterations) s << ' ' << it;
  s << "\nstop_translation_m " << stop_translation_m << " m\nstop_rotation_rad " << stop_rotation_rad << " rad"
    << "\nicp_weight " << icp_weight << "\nicp_sigma_m " << icp_sigma_m << " m\nicp_max_distance_m "
    << icp_max_distance_m << " m\nicp_max_normal_angle_deg " << icp_max_normal_angle_deg << " deg\nrgb_weight "
    << rgb_weight << "\nrgb_sigma_grey " << rgb_sigma_grey << " grey levels\nrgb_huber_k " << rgb_huber_k
    << " sigma\nrgb_max_depth_diff_m " << rgb_max_depth_diff_m << " m\nrgb_max_depth_m " << rgb_max_depth_m
    << " m\nlost_min_inlier_fraction " << lost_min_inlier_fraction << "\nlost_min_inliers " << lost_min_inliers
    << " px\nlost_max_icp_rms_m " << lost_max_icp_rms_m << " m\nlost_max_rgb_rms_grey " << lost_max_rgb_rms_grey
    << " grey levels\nlost_max_condition " << lost_max_condition << "\nlost_max_correction_m "
    << lost_max_correction_m << " m\nlost_max_correction_deg " << lost_max_correction_deg << " deg\n";
  return s.str();
}

Result<Tracker> Tracker::create(const Intrinsics& level0, int levels, const TrackerOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (!level0.valid()) return error(ErrorCode::kInvalidArgument, "Tracker: invalid intrinsics");
  if (levels < 1 || levels > kTrackerMaxLevels)
    return error(ErrorCode::kInvalidArgument, "Tracker: levels must be 1.." + std::to_string(kTrackerMaxLevels));
  const Intrinsics coarsest = level0.pyramid_level(levels - 1);
  if (coarsest.width < 8 || coarsest.height < 8)
    return error(ErrorCode::kInvalidArgument, "Tracker: coarsest level smaller than 8x8");
  Tracker t;
  t.options_ = options;
  t.level0_ = level0;
  t.levels_ = levels;
  t.capacity_ = static_cast<std::size_t>(level0.width) * level0.height;
  t.icp_rows_.reset(new float[kernels::kNeComponents * t.capacity_]());
  t.rgb_rows_.reset(new float[kernels::kNeComponents * t.capacity_]());
  return t;
}

Tracker::LevelStats Tracker::build_rows(const TrackerLevelView& ref, const TrackerLevelView& cur,
                                        const Eigen::Matrix3f& R, const Eigen::Vector3f& t, bool use_icp,
                                        bool use_rgb) {
  LevelStats st;
  const Intrinsics& k = ref.intrinsics;  // the reference camera: where current points are projected
  const int w = cur.intrinsics.width, h = cur.intrinsics.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  float* icp = icp_rows_.get();
  float* rgb = rgb_rows_.get();
  const float max_d2 = options_.icp_max_distance_m * options_.icp_max_distance_m;
  const float sin_gate = static_cast<float>(std::sin(options_.icp_max_normal_angle_deg * kDegToRad));
  const float sin2_gate = sin_gate * sin_gate;
  const float huber_grey = static_cast<float>(options_.rgb_huber_k * options_.rgb_sigma_grey);
  const float max_depth_diff = options_.rgb_max_depth_diff_m;
  const float max_depth = options_.rgb_max_depth_m;
  // Bilinear sampling needs the 2x2 block [x0, x0+1] x [y0, y0+1] inside the reference image.
  const float u_max = static_cast<float>(k.width - 1), v_max = static_cast<float>(k.height - 1);

  for (int y = 0; y < h; ++y) {
    const Eigen::Vector3f* cv = cur.vertex.row(y);
    const Eigen::Vector3f* cn = cur.normal.row(y);
    const float* ci = use_rgb ? cur.intensity.row(y) : nullptr;
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      bool icp_done = false, rgb_done = false;
      const Eigen::Vector3f& p = cv[x];
      if (p.z() > 0.0f) {
        ++st.valid;
        const Eigen::Vector3f X = R * p + t;  // in the reference camera frame
        if (X.z() > 0.0f) {
          const float inv_z = 1.0f / X.z();
          const float uf = k.fx * X.x() * inv_z + k.cx;
          const float vf = k.fy * X.y() * inv_z + k.cy;
          // Nearest reference pixel (projective association, KinectFusion section 3.5).
          const bool inside = uf > -0.5f && vf > -0.5f && uf < static_cast<float>(k.width) - 0.5f &&
                              vf < static_cast<float>(k.height) - 0.5f;
          const int ui = inside ? static_cast<int>(std::floor(uf + 0.5f)) : 0;
          const int vi = inside ? static_cast<int>(std::floor(vf + 0.5f)) : 0;
          const Eigen::Vector3f* q = inside ? &ref.vertex(ui, vi) : nullptr;
          const bool q_valid = q != nullptr && q->z() > 0.0f;

          if (use_icp && q_valid && valid_normal(cn[x])) {
            const Eigen::Vector3f& nr = ref.normal(ui, vi);
            if (valid_normal(nr)) {
              const Eigen::Vector3f d = X - *q;
              const Eigen::Vector3f Rn = R * cn[x];
              // sin^2 of the normal angle = |Rn x nr|^2 (both unit); same facing required.
              if (d.squaredNorm() <= max_d2 && Rn.dot(nr) > 0.0f && Rn.cross(nr).squaredNorm() <= sin2_gate) {
                put_row(icp, n, i, nr, X.cross(nr), nr.dot(d), 1.0f);
                icp_done = true;
                ++st.icp_inliers;
              }
            }
          }

          if (use_rgb && q_valid && X.z() <= max_depth && std::fabs(q->z() - X.z()) <= max_depth_diff && uf >= 0.0f &&
              vf >= 0.0f && uf < u_max && vf < v_max) {
            const int x0 = static_cast<int>(uf), y0 = static_cast<int>(vf);
            const float ax = uf - static_cast<float>(x0), ay = vf - static_cast<float>(y0);
            const float w00 = (1 - ax) * (1 - ay), w10 = ax * (1 - ay), w01 = (1 - ax) * ay, w11 = ax * ay;
            const auto bilinear = [&](const ImageView<const float>& im) {
              const float* r0 = im.row(y0);
              const float* r1 = im.row(y0 + 1);
              return w00 * r0[x0] + w10 * r0[x0 + 1] + w01 * r1[x0] + w11 * r1[x0 + 1];
            };
            const float r = bilinear(ref.intensity) - ci[x];
            const float gx = bilinear(ref.grad_x), gy = bilinear(ref.grad_y);
            // g = (d pi / dX)^T grad I_ref: the intensity change per metre of X.
            const float fgx = gx * k.fx * inv_z, fgy = gy * k.fy * inv_z;
            const Eigen::Vector3f g(fgx, fgy, -(fgx * X.x() + fgy * X.y()) * inv_z);
            const float a = std::fabs(r);
            const float weight = a <= huber_grey ? 1.0f : huber_grey / a;  // Huber IRLS weight
            put_row(rgb, n, i, g, X.cross(g), r, weight);
            rgb_done = true;
            ++st.rgb_inliers;
          }
        }
      }
      if (use_icp && !icp_done) put_zero_row(icp, n, i);
      if (use_rgb && !rgb_done) put_zero_row(rgb, n, i);
    }
  }
  return st;
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
  kernels::NormalEquations ne_icp, ne_rgb;
  bool diverged = false;

  // Builds and reduces the rows of level l at pose T; fills H and g. Returns the counts.
  const auto linearise = [&](int l, Matrix6d* H, Vector6d* g) {
    const Eigen::Matrix3f R = T.rotation_matrix().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    const bool use_rgb = rgb_level[l];
    const LevelStats st = build_rows(reference.level[l], current.level[l], R, t, icp_on, use_rgb);
    const std::size_t n = static_cast<std::size_t>(current.level[l].intrinsics.width) *
                          static_cast<std::size_t>(current.level[l].intrinsics.height);
    H->setZero();
    g->setZero();
    ne_icp = kernels::NormalEquations{};
    ne_rgb = kernels::NormalEquations{};
    if (icp_on) {
      kernels::reduce_normal_equations(icp_rows_.get(), n, n, &ne_icp);
      accumulate(ne_icp, c_icp, H, g);
    }
    if (use_rgb) {
      kernels::reduce_normal_equations(rgb_rows_.get(), n, n, &ne_rgb);
      accumulate(ne_rgb, c_rgb, H, g);
    }
    return st;
  };

  Matrix6d H;
  Vector6d g;
  for (int l = levels_ - 1; l >= 0 && !diverged; --l) {
    for (int it = 0; it < options_.iterations[l]; ++it) {
      const LevelStats st = linearise(l, &H, &g);
      if (st.icp_inliers + st.rgb_inliers < 6) break;  // nothing to solve on this level
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
      if (xi.head<3>().norm() < options_.stop_translation_m && xi.tail<3>().norm() < options_.stop_rotation_rad) break;
    }
  }

  // Quality at the final pose, level 0.
  const LevelStats st = linearise(0, &H, &g);
  res.T_ref_cur = T;
  res.valid_current = st.valid;
  res.icp_inliers = st.icp_inliers;
  res.rgb_inliers = st.rgb_inliers;
  res.icp_rms_m = st.icp_inliers > 0 ? std::sqrt(ne_icp.r2() / static_cast<double>(st.icp_inliers)) : 0.0;
  res.rgb_rms_grey = st.rgb_inliers > 0 ? std::sqrt(ne_rgb.r2() / static_cast<double>(st.rgb_inliers)) : 0.0;
  const int64_t judged = icp_on ? st.icp_inliers : st.rgb_inliers;
  res.inlier_fraction = st.valid > 0 ? static_cast<double>(judged) / static_cast<double>(st.valid) : 0.0;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(H, Eigen::EigenvaluesOnly);
  const double lmin = eig.eigenvalues()(0), lmax = eig.eigenvalues()(5);
  res.min_eigenvalue = lmin;
  res.condition = lmin > 0 ? lmax / lmin : std::numeric_limits<double>::infinity();

  const SE3 correction = T * T_ref_cur_guess.inverse();
  const bool correction_ok = correction.translation().norm() <= options_.lost_max_correction_m &&
                             correction.angle() <= options_.lost_max_correction_deg * kDegToRad;
  const bool rms_ok = icp_on ? res.icp_rms_m <= options_.lost_max_icp_rms_m
                             : res.rgb_rms_grey <= options_.lost_max_rgb_rms_grey;
  TrackLostReason reason = TrackLostReason::kNone;
  if (st.valid == 0 || (!icp_on && !rgb_level[0]))
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
