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
//   r_rgb_j = I_ref(pi(T p_j)) - g(u_j) I_cur(u_j)
//                                            grey levels (0..255). I_ref bilinear; gate: the reference
//                                            depth at the nearest pixel within rgb_max_depth_diff_m of
//                                            (T p_j).z, (T p_j).z <= rgb_max_depth_m, and I_ref's
//                                            gradient at least rgb_min_gradient_grey; g: the fitted
//                                            exposure-and-vignetting gain (rgb_gain; 1 when off)
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
// registered, hence the down-weighting and the Huber loss. Where the ICP term's own system is
// ill-conditioned (a near wall or corner), each step raises the RGB weight by up to rgb_boost_max
// (TrackerOptions::rgb_boost_condition says how and why).
//
// Twist convention (consistent with SE3::exp): xi = (v, w), v translation (metres), w rotation
// (axis-angle, radians), applied by LEFT multiplication: T <- exp(xi) * T. For a point x = T p in the
// reference frame, d(exp(xi) x)/dxi at 0 = [ I | -hat(x) ], so for a residual n . x the Jacobian row is
// (n^T, (x cross n)^T), and for the photometric one with g = (dpi/dx)^T grad I_ref it is
// (g^T, (x cross g)^T). Each Gauss-Newton step solves (J^T W J) xi = -J^T W r (6x6, Eigen LDLT).
//
// Pyramid: from the coarsest level to level 0, options.iterations[l] steps on level l (ElasticFusion:
// 10 / 5 / 4 fine to coarse). The rows (Jacobian, residual, weight) of a few image rows at a time
// (about 2048 pixels, so they stay in the L1/L2 cache) are written by kernels::track_rows (SIMD, the
// same bits on every ISA) into a small structure-of-arrays tile and reduced by
// kernels::reduce_normal_equations; the tiles' sums are added in double.
//
// SO(3) pre-alignment (ElasticFusion's default; options.so3_prealign): before the pyramid, a
// rotation-only photometric alignment on a small image (by default one more halving of the coarsest
// level, made here: 40x30 at 320x240) brings the rotation of the guess into the basin of the joint
// cost. For a pure rotation R the reference pixel of current pixel u is pi(R K^-1 u), whatever the
// depth, so the residual I_ref(pi(R K^-1 u)) - I_cur(u) needs no depth and every pixel counts (also
// those without depth); the rows are the photometric rows above with p = K^-1 u (a ray) and t = 0,
// and the step solves the 3x3 rotation block (Huber-weighted Gauss-Newton, R <- exp(w) R). The
// translation of the guess is kept. The result replaces the guess's rotation only if its mean robust
// photometric cost (sum w r^2 / pixels with a row) is below that of the guess. Measured on noise-free
// renders with an identity guess: the joint tracker alone ends in a wrong minimum for some rotations
// of 4-6 degrees and for every one tried of 8 degrees and more; with the pre-alignment, rotations up
// to 15 degrees (three axes tried) converge. On 7-Scenes it changes nothing for consecutive frames and
// keeps frames 10 and 15 apart tracked (tests/slam/test_tracker.cpp, bench/slam_track.cpp).
//
// Quality: TrackResult reports, on level 0 at the final pose, the ICP RMS, inliers, the conditioning
// of the solved system, and `lost` when a threshold of TrackerOptions is crossed. When the last
// level-0 step was below the stop thresholds (converged), the linearisation that computed that step
// supplies these figures (its pose differs from the final one by less than stop_translation_m /
// stop_rotation_rad); otherwise the residuals are evaluated once more at the final pose. A lost frame
// must not be fused.
//
// Not yet: multi-threaded row evaluation.
//
// Memory: track() performs no heap allocation; a Tracker holds the row tile (2 x 8 floats x ~2000
// pixels = 125 KiB at 320x240) and the SO(3) level (~34 KB at 40x30). Threads: one Tracker per thread.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/options.h"
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
  // A level stops early when the step is below both (metres, radians); the step that was below is
  // still applied, and Gauss-Newton so close to the minimum leaves far less than it. 1 mm / 0.057 deg
  // (frame-to-frame errors on 7-Scenes are 2.1 mm / 0.089 deg median). Measured with
  // bench/slam_track.cpp (200 7-Scenes pairs, gaps of 1 and 3 frames): 1e-4, 4e-4 and 1e-3 give the
  // same errors (medians within 0.03 mm and 0.004 deg) with 7.1, 5.8 and 4.5 Gauss-Newton steps per
  // frame at gap 1 (level 0: 2.1, 1.4, 1.0); the whole SLAM on 7-Scenes' 1000 frames: ATE 2.76,
  // 2.75, 2.73 cm, tracking 4.34 -> 3.05 ms (1e-4 -> 4e-4, side by side); the synthetic 1000-frame
  // loop: 5.6, 5.5, 5.5 mm. (Earlier: 1e-4 gave the errors of 1e-5 with a third fewer steps.)
  double stop_translation_m = 1e-3;
  double stop_rotation_rad = 1e-3;

  // --- SO(3) pre-alignment (see above; ElasticFusion: on; here off by default) ---
  // Runs only when both frames have intensity on that level. Off by default: it widens the basin
  // of frame-to-frame tracking for large rotations (tests/slam/test_tracker.cpp), but in the
  // frame-to-model pipeline on the default synthetic sequence (living room, 300-frame loop) the
  // rotation it found on the hole-filled predicted image sent tracking into a wrong minimum at
  // frame 27 and every later frame was lost (ATE 1.46 m against 5.7 mm without it), while on
  // 7-Scenes it changed nothing (400 frames: 3.95 against 3.90 cm).
  bool so3_prealign = false;
  // Gauss-Newton steps at most (0..100); stops early when the rotation step is below
  // stop_rotation_rad. Small rotations take ~5 steps; 20 lets ~15 degrees converge on 40x30.
  int so3_iterations = 20;
  // Pyramid level it runs on: 0..levels-1 are the frames' levels; `levels` is one more halving of
  // the coarsest level that the tracker makes itself (intensity 4x4 binomial and Sobel gradients,
  // as the preprocessor). -1 (default) = that extra level when it is at least 16x12 pixels (40x30
  // at 320x240 with 3 levels), else the coarsest.
  int so3_level = -1;

  // --- ICP (point-to-plane, projective association) ---
  // Relative weight of the ICP term (dimensionless, >= 0; 0 = RGB only). ElasticFusion ICP:RGB = 10.
  double icp_weight = 10.0;
  // Weight each ICP row by (sigma(z_ref) / sigma(z))^2, capped at 4, with z the current point's
  // depth and sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 metres, the axial noise of a structured-light
  // depth camera (Nguyen, Izadi, Lovell, 3DIMPVT 2012), z_ref = icp_depth_weight_ref_m. Far points
  // are noisier and quantised into coarser disparity steps that stay fixed in the camera, which
  // biases ICP towards "no motion"; down-weighting them cut the drift on 7-Scenes (see
  // docs/results.md). The weights are then rescaled to a mean of 1 over the inliers, so the ICP
  // term keeps its weight against the photometric one. false: every row weighs 1.
  bool icp_depth_weighting = true;
  float icp_depth_weight_ref_m = 1.0f;  // metres, > 0.4
  // Normalising scale of the point-to-plane residual, metres (> 0): typical depth noise.
  double icp_sigma_m = 0.01;
  // Association gates: point distance, metres (ElasticFusion 0.10 m), and the angle between the
  // rotated current normal and the reference normal, degrees (ElasticFusion sin(20 deg)).
  float icp_max_distance_m = 0.10f;
  float icp_max_normal_angle_deg = 20.0f;

  // --- photometric ---
  // Relative weight of the RGB term (dimensionless, >= 0; 0 = ICP only). 0.25, i.e. ICP:RGB = 40
  // (ElasticFusion: 10), measured frame to model with the depth-weighted ICP: 7-Scenes 1000 frames
  // ATE 2.77 cm at 0.25 against 3.58 cm at 1; 400 frames 2.30 / 2.42 cm (0.1: 2.32); the synthetic
  // 1000-frame loop with noise 5.3 mm at 0.25. 7-Scenes colour is not registered to its depth, and
  // the synthetic rooms are weakly textured: geometry is the better-conditioned term in both.
  double rgb_weight = 0.25;
  // The RGB weight rises where ICP alone does not pin the pose (a wall, a corner seen from close
  // by): on each Gauss-Newton step it is multiplied by clamp(c / rgb_boost_condition, 1,
  // rgb_boost_max), c the condition number of the ICP term's own 6x6 system at that step
  // (normalised as lost_max_condition). Why: a constant weight must choose between the two failure
  // modes. 7-Scenes' colour is not registered to its depth and a strong RGB term costs ATE there
  // (rgb_weight 4: 3.89 cm against 2.67), but the inspecting synthetic scans, whose views of a near
  // wall leave ICP one direction it cannot see, slip to wrong minima at 0.25 (ATE up to 1.66 m) and
  // track within 9.3 mm at 4. Measured ICP-only condition at the end of every level of every frame:
  // 7-Scenes 72-371 (1000 frames), the synthetic scans up to 5e4, above 3e3 in a tenth. The factor is
  // at most 16 (= rgb_weight 4) where ICP is blind. 500 against 1000, with the last pose as the guess
  // (docs/results.md, SLAM, "Tracking a close inspecting scan"): 7-Scenes ATE 2.66 / 2.67 cm; the
  // eleven synthetic scans all within 11 mm but office (114 / 105 mm) and seed 5005 (237 / 268 mm) at
  // 500; library 42 mm at 500 but 732 mm and 225 lost frames at 1000. With the constant-velocity
  // guess (SurfelSlamOptions, the default) both hold every scan within 11.5 mm.
  // rgb_boost_condition 0 turns it off (the weight is rgb_weight everywhere).
  double rgb_boost_condition = 500.0;   // dimensionless, 0 (off) or > 1
  double rgb_boost_max = 16.0;          // factor, >= 1
  // Normalising scale of the intensity residual, grey levels (0..255 scale, > 0).
  double rgb_sigma_grey = 10.0;
  // Huber threshold in units of rgb_sigma_grey (> 0): residuals beyond it get weight k / |r|.
  double rgb_huber_k = 1.5;
  // Texture gate, grey levels per pixel of the level (0..255; 0 = every pixel): a photometric row
  // needs the predicted image's gradient magnitude at least this (DVO and ElasticFusion skip
  // untextured pixels too). Why: on a bare wall the only gradients are those of vignetting and
  // shading, a few tenths of a grey level per pixel, and the Kinect-like synthetic camera's
  // vignetting (fixed in the image while the map's colours average many views) then drags the pose:
  // the seed-7 inspecting scan slid 4 cm a frame along the wall from frame 3 on (ATE 79 cm, 41 lost).
  // Measured with rgb_gain on (seed 7, 300 frames): 0 -> 72 cm, 1.5 -> 6.5 mm; without the gain,
  // 1 grey level still slid 3 cm a frame, 2 and 3 tracked. Kept low because shading is real signal
  // on the ideal camera's untextured scans: 3 without the gain lost seed 5006 (220 frames, 1.3 m);
  // 1.5 with the gain holds every one of the eleven within 21 mm (bench/relocalisation.py --scans).
  // 7-Scenes without the gain: 2.66 cm at 0, 1.5 or 3.
  double rgb_min_gradient_grey = 1.5;
  // Photometric compensation: the photometric residual compares the prediction with the current
  // image times a gain fitted to the pair as the pose is (PhotoGain), a0 + a2 rho (rho the
  // squared image radius, 1 about the corners). Why: a consumer camera's auto-exposure changes the
  // whole image's brightness from frame to frame, and its vignetting darkens the corners in every
  // frame while the map's colours average many views; both leave residuals that pull the pose where
  // ICP cannot hold it (a near wall). The fit uses the pixels with a photometric row, weighted by
  // their Huber weights, so a misaligned edge or an occlusion counts little. Measured on the
  // Kinect-like synthetic inspecting scans, 300 frames (rgb_min_gradient_grey 1.5): seed 3 62 cm
  // without it (the camera model's exposure alone does that: 55 cm with its other effects off), 5.3
  // mm with it; seed 6 19 cm -> 4.5 mm; seeds 1, 2, 4, 5, 8 unchanged (4.5-8.5 mm); seed 7 needs it
  // and the texture gate together (72 cm with the gain alone, 6.5 mm with both). Real 7-Scenes
  // (1000 frames): ATE 2.69 cm with it, 2.66 without; tracking 1.80 ms a frame against 1.56 (median,
  // one run each, 2 cores of an AMD EPYC): the current rows are scaled on every level-0 step too,
  // the fit is made on the coarse levels only.
  bool rgb_gain = true;
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
  // The fewest inliers the two tests above allow among `pixels` valid ones: what a model that
  // covers fewer pixels can never pass (SurfelSlam's loop check skips registering against it).
  double min_inliers_among(double pixels) const {
    return std::max(static_cast<double>(lost_min_inliers), lost_min_inlier_fraction * pixels);
  }
  // RMS of the ICP inlier residuals, metres. (RGB only: RMS of the RGB residuals, grey levels.)
  double lost_max_icp_rms_m = 0.02;
  double lost_max_rgb_rms_grey = 40.0;
  // Condition number (largest / smallest eigenvalue) of the solved 6x6 system, normalised as above
  // (translation in metres, rotation in radians): larger = a direction the data does not constrain.
  // Measured: 65-590 for ICP and joint tracking of rooms (synthetic and 7-Scenes), 3e3-6e3 for RGB
  // alone, 4.8e4-6e4 for ICP on a single plane (3 unconstrained directions; not infinite because the
  // border normals of the filtered depth are slightly bent), 150 for a textured plane tracked jointly.
  // Joint tracking at the final pose of every frame (stop 52): 7-Scenes at most 272; the ten other
  // inspecting scans at most 8.9e3, the Kinect-like seed 7 before its bare wall 6.1e3 (its noisy
  // normals see every direction a little); the inspecting scan seed 5005, whose far wall is beyond
  // the depth range for some 40 frames (floor, ceiling and one side wall: the forward direction held
  // by RGB and a few edges), 1.3e4 fusing every pixel and up to 2.9e4 fusing every other
  // (mapping.fusion_stride 2), with one weak direction only (the second weakest at most 4.2e3).
  // There the pose stays right (ATE 12.5 mm over the 1200 frames, the worst frame 41 mm) where 2e4,
  // the earlier limit, declared 133 frames lost, and lost frames left the model without the new
  // surface, so tracking never came back (ATE 1.12 m). Hence 4e4: above what a weak but seen
  // direction gave, below the blind plane.
  double lost_max_condition = 4e4;
  // Largest correction of the caller's guess, metres and degrees: beyond it the solution diverged.
  double lost_max_correction_m = 0.3;
  double lost_max_correction_deg = 20.0;

  // The keys `run` offers (section mapping): icp_weight, rgb_weight, rgb_boost_condition, rgb_boost_max,
  // rgb_min_gradient, rgb_gain, lost_max_condition.
  static const opt::Table<TrackerOptions>& table();
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
  kInliersDropped,  // far fewer inliers than the frames before it (SurfelSlamOptions::lost_inlier_drop)
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
  double rgb_boost = 1;         // the factor on rgb_weight (options.rgb_boost_*) at the final pose
  int64_t rgb_inliers = 0;      // current pixels passing the photometric gates
  double gain_a0 = 1, gain_a2 = 0;  // the photometric gain at the end (options.rgb_gain; 1, 0 when off)
  int64_t valid_current = 0;    // current pixels with a valid vertex
  double min_eigenvalue = 0;    // of the normalised, weighted 6x6 system at the final pose
  double condition = 0;         // largest / smallest eigenvalue of it (inf if singular)
  int iterations = 0;           // Gauss-Newton steps taken, all levels (SO(3) steps not included)
  std::array<int, kTrackerMaxLevels> level_iterations{};

  // SO(3) pre-alignment: steps taken, whether its rotation replaced the guess's, and the angle of
  // that change (degrees; 0 when not applied).
  int so3_iterations = 0;
  bool so3_applied = false;
  double so3_rotation_deg = 0;
};

class Tracker {
 public:
  // Allocates the row tiles and the SO(3) level for pyramids whose level 0 is level0.width x
  // level0.height (coarser levels are the halvings of Intrinsics::pyramid_level). Errors: invalid
  // options or size.
  static Result<Tracker> create(const Intrinsics& level0, int levels, const TrackerOptions& options = {});
  // Bytes create() allocates for a level 0 of width x height pixels, `levels` levels and these
  // options (the memory plan's figure); bytes() of a created tracker, from what it holds.
  static std::size_t bytes_for(int width, int height, int levels, const TrackerOptions& options);
  std::size_t bytes() const;

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
  static constexpr int kNeUpper = 28;  // kernels::kNeOutputs
  // Sums of the reduced rows of one linearisation, and the pixel counts.
  struct Linearisation {
    double icp[kNeUpper] = {}, rgb[kNeUpper] = {};  // upper triangles as kernels::NormalEquations
    int64_t valid = 0, icp_inliers = 0, rgb_inliers = 0;
    // Weighted sums of the radial gain fit (PhotoGain::refit): ss[0..2] = sum w c^2 (1, rho, rho^2),
    // sb[0..1] = sum w B(I_ref) c (1, rho); c the current intensity, rho its normalised radius^2.
    double ss[3] = {}, sb[2] = {};
  };
  // The current image's brightness relative to the prediction, as a gain that varies with the
  // squared image radius: B(I_ref) ~ (a0 + a2 rho) c, rho = |u - principal point|^2 / |principal
  // point|^2 (about 1 in the corners). Exposure is a0; vignetting is a2 (see
  // TrackerOptions::rgb_gain). Reset to (1, 0) for each track(), refitted after every linearisation
  // of the SO(3) level and of the pyramid's coarser levels from its photometric rows, and applied
  // unchanged on level 0 (a fit there would cost a pass over every pixel for a gain the coarse
  // levels already measure).
  struct PhotoGain {
    double a0 = 1, a2 = 0;
    void refit(const Linearisation& lin);
  };
  // Evaluates and reduces the rows of level l at pose (R, t). rays: use these xyz rays instead of the
  // current vertices (the SO(3) mode: RGB only, no depth gate).
  float weight_icp_rows_by_depth(const float* vertex, std::size_t n, float* weights) const;
  // Adds the fit sums of image rows y0..y1 of the tile (residuals: component 6, weights: 7) to out;
  // pixels without a photometric row (weight 0) add nothing.
  void fit_gain(const TrackerLevelView& cur, int y0, int y1, const PhotoGain& gain, const float* residuals,
                const float* weights, Linearisation* out) const;
  // gain: when not null, the photometric rows compare the prediction with the current image times
  // the gain (rows in gain_row_); fit: also fill out's fit sums (PhotoGain::refit).
  void linearise(const TrackerLevelView& ref, const TrackerLevelView& cur, const Eigen::Matrix3f& R,
                 const Eigen::Vector3f& t, bool use_icp, bool use_rgb, const float* rays, const PhotoGain* gain,
                 bool fit, Linearisation* out);
  // The SO(3) pre-alignment: returns the rotation to start from (R0 when it does not help).
  Eigen::Matrix3d prealign_rotation(const TrackerLevelView& ref, const TrackerLevelView& cur,
                                    const Eigen::Matrix3d& R0, PhotoGain* gain, TrackResult* res);

  TrackerOptions options_;
  Intrinsics level0_;
  int levels_ = 0;
  int so3_level_ = 0;                     // resolved options_.so3_level (levels_ = the extra level)
  std::size_t tile_capacity_ = 0;         // pixels per tile (whole image rows of any level)
  std::unique_ptr<float[]> tile_;         // 2 x 8 x tile_capacity_ floats: ICP rows, then RGB rows (SoA)
  std::unique_ptr<float[]> gain_row_;     // one level-0 row (level0_.width) of the current intensity times the gain
  std::unique_ptr<float[]> rays_;         // K^-1 (x, y, 1) per pixel of so3_level_, xyz, row-major
  // The extra SO(3) level (when so3_level_ == levels_): intensities (grey levels) and the
  // reference's gradients (grey levels per pixel of that level).
  Image<float> so3_ref_intensity_, so3_ref_grad_x_, so3_ref_grad_y_, so3_cur_intensity_;
};

}  // namespace ef::slam
