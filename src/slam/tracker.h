// Camera tracking: the relative pose between a reference (model) and the current frame by joint
// point-to-plane ICP and photometric alignment, coarse to fine, Gauss-Newton on SE3.
//
// The cost follows ElasticFusion (Whelan et al., RSS 2015, section 4.1 "Tracking"), whose geometric
// term is KinectFusion's projective point-to-plane ICP (Newcombe et al., ISMAR 2011, section 3.5) and
// whose photometric term aligns intensities with the reference image (as in DVO / Kerl et al. 2013):
//
//   E(T) = icp_weight * sum_i (r_icp_i / icp_sigma_m)^2 + rgb_weight * sum_j rho((r_rgb_j / rgb_sigma_grey))
//
//   r_icp_i = n_i . (T p_i - q_i)            metres. p_i: current vertex (current camera frame);
//                                            T = T_ref_cur; q_i, n_i: reference vertex / normal at the
//                                            reference pixel nearest to pi(T p_i) (projective data
//                                            association); gates: |T p_i - q_i| <= icp_max_distance_m,
//                                            sin(angle(R n_cur_i, n_i)) <= sin(icp_max_normal_angle_deg)
//   r_rgb_j = I_ref(pi(T p_j)) - I_cur(u_j)  grey levels (0..255). I_ref bilinear; gate: the reference
//                                            depth at the nearest pixel within rgb_max_depth_diff_m of
//                                            (T p_j).z, and (T p_j).z <= rgb_max_depth_m
//   rho                                      Huber with threshold rgb_huber_k (in units of sigma),
//                                            applied as an iteratively reweighted least-squares weight
//
// How the relative weight is applied: both residuals are first made dimensionless by their sigma
// (metres and grey levels are otherwise ~1e7 apart in squared units), then the ICP system is
// multiplied by icp_weight and the RGB one by rgb_weight. ElasticFusion's "ICP:RGB weight 10" is
// icp_weight / rgb_weight = 10 (its 0 = RGB only is icp_weight = 0; its 100 = ICP only is
// rgb_weight = 0 here). With the defaults (sigma 1 cm and 10 grey levels) a geometrically
// well-constrained direction is dominated by ICP; RGB matters where the geometry is degenerate (a wall,
// a floor), which is what the joint term is for. 7-Scenes colour and depth are not precisely
// registered, hence the down-weighting and the Huber loss.
//
// Twist convention (consistent with SE3::exp): xi = (v, w), v translation (metres), w rotation
// (axis-angle, radians), applied by LEFT multiplication: T <- exp(xi) * T. For a point x = T p in the
// reference frame, d(exp(xi) x)/dxi at 0 = [ I | -hat(x) ], so for a residual n . x the Jacobian row is
// (n^T, (x cross n)^T), and for the photometric one with g = (dpi/dx)^T grad I_ref it is
// (g^T, (x cross g)^T). Each Gauss-Newton step solves (J^T W J) xi = -J^T W r (6x6, Eigen LDLT).
//
// Pyramid: from the coarsest level to level 0, options.iterations[l] steps on level l (ElasticFusion:
// 10 / 5 / 4 fine to coarse). The rows (Jacobian, residual, weight) are written into structure-of-
// arrays buffers allocated by Tracker::create() and reduced by kernels::reduce_normal_equations.
//
// Quality: after the last step the residuals are evaluated once more at the final pose on level 0;
// TrackResult reports the ICP RMS, inliers, the conditioning of the solved system, and `lost` when
// a threshold of TrackerOptions is crossed. A lost frame must not be fused.
//
// Not yet: ElasticFusion's SO(3) photometric pre-alignment (the caller's guess must be within the
// basin of the coarse level: a few centimetres / degrees), and multi-threaded row evaluation.
//
// Memory: track() performs no heap allocation. Threads: one Tracker per thread.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/result.h"
#include "core/se3.h"

namespace ef::slam {

class Preprocessor;

inline constexpr int kTrackerMaxLevels = 6;

// One pyramid level as the tracker reads it. Every image has intrinsics.width x intrinsics.height
// pixels; conventions as in slam/preprocess.h (camera frame, metres, invalid vertex z <= 0, invalid
// normal = 0, intensity 0..255 grey levels, gradients in grey levels per pixel of this level).
// Reference: vertex, normal, intensity, grad_x, grad_y are read. Current: vertex, normal, intensity.
struct TrackerLevelView {
  Intrinsics intrinsics;
  ImageView<const Eigen::Vector3f> vertex;
  ImageView<const Eigen::Vector3f> normal;
  ImageView<const float> intensity;  // may be empty: no photometric term on this level
  ImageView<const float> grad_x;     // needed for the reference only
  ImageView<const float> grad_y;
};

// A pyramid of maps in one camera frame: the preprocessed current frame, the previous frame
// (frame-to-frame), or the model's maps predicted (rendered) at the reference pose.
struct PyramidView {
  int levels = 0;
  TrackerLevelView level[kTrackerMaxLevels];
};

// A view of the preprocessor's current pyramid (valid until its next process()). Intensity views
// are left empty when the frame had no colour.
PyramidView pyramid_view(const Preprocessor& p);

struct TrackerOptions {
  // Gauss-Newton steps per level, index = level (0 = finest). ElasticFusion: 10 / 5 / 4 fine to
  // coarse, so the coarsest of 3 levels gets 4. Each 0..100; levels beyond the pyramid are ignored.
  std::array<int, kTrackerMaxLevels> iterations{{10, 5, 4, 4, 4, 4}};
  // A level stops early when the step is below both (metres, radians).
  double stop_translation_m = 1e-5;
  double stop_rotation_rad = 1e-5;

  // --- ICP (point-to-plane, projective association) ---
  // Relative weight of the ICP term (dimensionless, >= 0; 0 = RGB only). ElasticFusion ICP:RGB = 10.
  double icp_weight = 10.0;
  // Normalising scale of the point-to-plane residual, metres (> 0): typical depth noise.
  double icp_sigma_m = 0.01;
  // Association gates: point distance, metres (ElasticFusion 0.10 m), and the angle between the
  // rotated current normal and the reference normal, degrees (ElasticFusion sin(20 deg)).
  float icp_max_distance_m = 0.10f;
  float icp_max_normal_angle_deg = 20.0f;

  // --- photometric ---
  // Relative weight of the RGB term (dimensionless, >= 0; 0 = ICP only).
  double rgb_weight = 1.0;
  // Normalising scale of the intensity residual, grey levels (0..255 scale, > 0).
  double rgb_sigma_grey = 10.0;
  // Huber threshold in units of rgb_sigma_grey (> 0): residuals beyond it get weight k / |r|.
  double rgb_huber_k = 1.5;
  // Gates: |reference depth - warped depth|, metres (ElasticFusion 0.07 m); warped depth at most
  // this, metres (ElasticFusion 6 m).
  float rgb_max_depth_diff_m = 0.07f;
  float rgb_max_depth_m = 6.0f;

  // --- lost: the frame must not be fused when any of these fails (evaluated on level 0 at the
  // final pose) ---
  // ICP inliers / valid current vertices (fraction 0..1), and an absolute floor (pixels of level 0).
  // For an RGB-only tracker (icp_weight = 0) the RGB inliers are judged instead. Measured at the
  // right pose: 0.79 on 7-Scenes, 0.9 on noise-free synthetic frames, but only 0.15-0.20 on the noisy
  // synthetic ones (their level-0 normals are noisy enough that the 20-degree normal gate rejects
  // most pixels), hence 0.1; a frame of another room gave 0.02.
  double lost_min_inlier_fraction = 0.1;
  int64_t lost_min_inliers = 1000;
  // RMS of the ICP inlier residuals, metres. (RGB only: RMS of the RGB residuals, grey levels.)
  double lost_max_icp_rms_m = 0.02;
  double lost_max_rgb_rms_grey = 40.0;
  // Condition number (largest / smallest eigenvalue) of the solved 6x6 system, normalised as above
  // (translation in metres, rotation in radians): larger = a direction the data does not constrain.
  // Measured: 65-590 for ICP and joint tracking of rooms (synthetic and 7-Scenes), 3e3-6e3 for RGB
  // alone, 6e4 for ICP on a single plane (3 unconstrained directions; not infinite because the
  // border normals of the filtered depth are slightly bent), 150 for a textured plane tracked jointly.
  double lost_max_condition = 2e4;
  // Largest correction of the caller's guess, metres and degrees: beyond it the solution diverged.
  double lost_max_correction_m = 0.3;
  double lost_max_correction_deg = 20.0;

  // An error naming the first field out of range.
  Status validate() const;
  // One line per field with its unit, for logs.
  std::string describe() const;
};

enum class TrackLostReason {
  kNone = 0,
  kNoData,          // no valid current vertex, or no term enabled with data
  kTooFewInliers,   // below lost_min_inliers or lost_min_inlier_fraction
  kResidualTooLarge,
  kIllConditioned,  // condition number above lost_max_condition, or a singular system
  kDiverged,        // correction beyond lost_max_correction_*, or a non-finite step
};
const char* track_lost_reason_name(TrackLostReason r);

struct TrackResult {
  SE3 T_ref_cur;               // the estimate: maps current-camera points into the reference frame
                               // (the last iterate, also when lost: then do not use it)
  bool lost = true;            // true: do not fuse this frame (see `reason`)
  TrackLostReason reason = TrackLostReason::kNoData;

  // At the final pose, level 0:
  double icp_rms_m = 0;         // sqrt(mean r_icp^2) over ICP inliers, metres
  int64_t icp_inliers = 0;      // current pixels passing the ICP gates
  double inlier_fraction = 0;   // icp_inliers (rgb_inliers when ICP is off) / valid current vertices
  double rgb_rms_grey = 0;      // sqrt(sum w r_rgb^2 / rgb_inliers), w the Huber weights, grey levels
  int64_t rgb_inliers = 0;      // current pixels passing the photometric gates
  int64_t valid_current = 0;    // current pixels with a valid vertex
  double min_eigenvalue = 0;    // of the normalised, weighted 6x6 system at the final pose
  double condition = 0;         // largest / smallest eigenvalue of it (inf if singular)
  int iterations = 0;           // Gauss-Newton steps taken, all levels
  std::array<int, kTrackerMaxLevels> level_iterations{};
};

class Tracker {
 public:
  // Allocates the row buffers for pyramids whose level 0 is level0.width x level0.height (coarser
  // levels are the halvings of Intrinsics::pyramid_level). Errors: invalid options or size.
  static Result<Tracker> create(const Intrinsics& level0, int levels, const TrackerOptions& options = {});

  // Estimates T_ref_cur starting from `T_ref_cur_guess` (identity for frame-to-frame with no motion
  // model). Both pyramids must have at least levels() levels of the sizes given at create()
  // (otherwise kInvalidArgument). Tracking failure is not an error: it is result->lost.
  // No heap allocation.
  Status track(const PyramidView& reference, const PyramidView& current, const SE3& T_ref_cur_guess,
               TrackResult* result);

  int levels() const { return levels_; }
  const TrackerOptions& options() const { return options_; }

 private:
  Tracker() = default;
  struct LevelStats {
    int64_t icp_inliers = 0, rgb_inliers = 0, valid = 0;
  };
  // Writes the rows of level l at pose T (into icp_rows_ / rgb_rows_), returns the counts.
  LevelStats build_rows(const TrackerLevelView& ref, const TrackerLevelView& cur, const Eigen::Matrix3f& R,
                        const Eigen::Vector3f& t, bool use_icp, bool use_rgb);

  TrackerOptions options_;
  Intrinsics level0_;
  int levels_ = 0;
  std::size_t capacity_ = 0;             // rows per term: pixels of level 0
  std::unique_ptr<float[]> icp_rows_;    // 8 x capacity_ floats, SoA (kernels/normal_equations.h)
  std::unique_ptr<float[]> rgb_rows_;
};

}  // namespace ef::slam
