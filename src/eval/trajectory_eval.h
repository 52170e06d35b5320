// Trajectory accuracy as in the TUM RGB-D benchmark (Sturm et al., IROS 2012):
//   ATE  absolute trajectory error: RMSE of the translation differences after the least-squares
//        rigid alignment (rotation + translation, no scale; Horn / Umeyama) of the estimated
//        positions onto the ground-truth positions, poses associated by timestamp.
//   RPE  relative pose error over a fixed frame delta: E_i = (G_i^-1 G_{i+d})^-1 (P_i^-1 P_{i+d}).
// Units: metres, degrees, seconds.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/result.h"
#include "core/se3.h"
#include "io/trajectory_io.h"

namespace ef {

// associate_timestamps() of core/time_association.h applied to two trajectories' stamps
// (|t_a - t_b| < max_dt, greedy by smallest difference, as TUM's associate.py). Returns
// (index in a, index in b) pairs sorted by index in a.
std::vector<std::pair<int, int>> associate_timestamps(const std::vector<TimedPose>& a, const std::vector<TimedPose>& b,
                                                      double max_dt);

// Least-squares rigid transform T (no scale) minimising sum |dst_i - T * src_i|^2 (Umeyama 1991
// with scale fixed to 1). Needs at least 3 points; collinear points give one of the minimisers.
SE3 align_rigid(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

struct AteResult {
  double rmse_m = 0;
  double mean_m = 0;
  double median_m = 0;
  double max_m = 0;
  int pairs = 0;                // associated poses used
  SE3 T_gt_est;                 // alignment applied to the estimate: p_gt ~ T_gt_est * p_est
  std::vector<double> errors_m; // per associated pair, in ground-truth time order
  std::string warnings;         // from the *_files readers: a cut last line left out, repeated timestamps (one per line)
};

// Errors (naming both trajectories' sources): fewer than 3 associated pairs, max_dt <= 0 (pairs nothing).
Result<AteResult> evaluate_ate(const Trajectory& gt, const Trajectory& est, double max_dt = 0.02);

struct RpeResult {
  double trans_rmse_m = 0;
  double trans_mean_m = 0;
  double trans_median_m = 0;
  double trans_max_m = 0;
  double rot_rmse_deg = 0;
  double rot_mean_deg = 0;
  double rot_max_deg = 0;
  int pairs = 0;  // relative-pose pairs (i, i + delta) evaluated
  std::string warnings;  // from the *_files readers: a cut last line left out, repeated timestamps (one per line)
};

// delta_frames counts associated poses in estimate order (pose i against pose i + delta among the
// poses that found a ground-truth partner). No alignment is needed: relative motions are
// frame-independent. Errors: delta_frames < 1, no pair (i, i + delta) after association.
Result<RpeResult> evaluate_rpe(const Trajectory& gt, const Trajectory& est, int delta_frames, double max_dt = 0.02);

// Reads both files and evaluates; errors from reading name the file and line. A file whose last line
// was cut while written (a killed run) is evaluated without it, and `warnings` says so.
Result<AteResult> evaluate_ate_files(const std::string& gt_path, const std::string& est_path, double max_dt = 0.02);
Result<RpeResult> evaluate_rpe_files(const std::string& gt_path, const std::string& est_path, int delta_frames,
                                     double max_dt = 0.02);

// Machine-readable "key value" lines, one per metric:
//   ate_rmse_m, ate_mean_m, ate_median_m, ate_max_m, pairs
//   rpe_trans_rmse_m, rpe_trans_mean_m, rpe_trans_median_m, rpe_trans_max_m, rpe_rot_rmse_deg, rpe_rot_mean_deg,
//   rpe_rot_max_deg, pairs
std::string format_ate(const AteResult& r);
std::string format_rpe(const RpeResult& r);

}  // namespace ef
