#include "eval/trajectory_eval.h"

#include "core/time_association.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ef {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct Summary {
  double rmse = 0, mean = 0, median = 0, max = 0;
};

Summary summarise(std::vector<double> v) {
  Summary s;
  if (v.empty()) return s;
  double sum = 0, sum2 = 0;
  for (double e : v) {
    sum += e;
    sum2 += e * e;
    s.max = std::max(s.max, e);
  }
  const double n = static_cast<double>(v.size());
  s.rmse = std::sqrt(sum2 / n);
  s.mean = sum / n;
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  s.median = v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
  return s;
}

std::string names(const Trajectory& gt, const Trajectory& est) {
  return "ground truth '" + gt.source + "' vs estimate '" + est.source + "'";
}

}  // namespace

std::vector<std::pair<int, int>> associate_timestamps(const std::vector<TimedPose>& a, const std::vector<TimedPose>& b,
                                                      double max_dt) {
  std::vector<double> ta(a.size()), tb(b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ta[i] = a[i].timestamp;
  for (std::size_t j = 0; j < b.size(); ++j) tb[j] = b[j].timestamp;
  std::vector<std::pair<int, int>> out;
  for (const auto& [i, j] : associate_timestamps(ta, tb, max_dt)) out.emplace_back(static_cast<int>(i), static_cast<int>(j));
  return out;
}

SE3 align_rigid(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  const std::size_t n = std::min(src.size(), dst.size());
  if (n == 0) return SE3();
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero(), mu_d = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mu_s += src[i];
    mu_d += dst[i];
  }
  mu_s /= static_cast<double>(n);
  mu_d /= static_cast<double>(n);
  // Cross-covariance Sigma = sum (d_i - mu_d)(s_i - mu_s)^T; R = U S V^T with S fixing det(R) = +1.
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) sigma += (dst[i] - mu_d) * (src[i] - mu_s).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  const Eigen::Vector3d t = mu_d - R * mu_s;
  return SE3(R, t);
}

Result<AteResult> evaluate_ate(const Trajectory& gt, const Trajectory& est, double max_dt) {
  if (!(max_dt > 0)) return error(ErrorCode::kInvalidArgument, "ATE: max_dt must be > 0 seconds (0 pairs nothing)");
  const auto matches = associate_timestamps(gt.poses, est.poses, max_dt);
  if (matches.size() < 3) {
    char buf[160];
    std::snprintf(buf, sizeof buf, ": only %zu poses associated within max_dt %.4g s (%zu and %zu poses); need at least 3",
                  matches.size(), max_dt, gt.poses.size(), est.poses.size());
    return error(ErrorCode::kInvalidArgument, "ATE: " + names(gt, est) + buf);
  }
  std::vector<Eigen::Vector3d> p_est, p_gt;
  p_est.reserve(matches.size());
  p_gt.reserve(matches.size());
  for (const auto& [i, j] : matches) {
    p_gt.push_back(gt.poses[i].T_wc.translation());
    p_est.push_back(est.poses[j].T_wc.translation());
  }
  AteResult r;
  r.T_gt_est = align_rigid(p_est, p_gt);
  r.pairs = static_cast<int>(matches.size());
  r.errors_m.reserve(matches.size());
  for (std::size_t k = 0; k < matches.size(); ++k) r.errors_m.push_back((r.T_gt_est * p_est[k] - p_gt[k]).norm());
  const Summary s = summarise(r.errors_m);
  r.rmse_m = s.rmse;
  r.mean_m = s.mean;
  r.median_m = s.median;
  r.max_m = s.max;
  return r;
}

Result<RpeResult> evaluate_rpe(const Trajectory& gt, const Trajectory& est, int delta_frames, double max_dt) {
  if (delta_frames < 1) return error(ErrorCode::kInvalidArgument, "RPE: delta_frames must be >= 1");
  if (!(max_dt > 0)) return error(ErrorCode::kInvalidArgument, "RPE: max_dt must be > 0 seconds (0 pairs nothing)");
  // Associate in estimate order: pairs are (est index, gt index).
  const auto matches = associate_timestamps(est.poses, gt.poses, max_dt);
  const int n = static_cast<int>(matches.size());
  if (n <= delta_frames) {
    return error(ErrorCode::kInvalidArgument, "RPE: " + names(gt, est) + ": " + std::to_string(n) +
                 " poses associated, not enough for a frame delta of " + std::to_string(delta_frames));
  }
  std::vector<double> et, er;
  et.reserve(n - delta_frames);
  er.reserve(n - delta_frames);
  for (int k = 0; k + delta_frames < n; ++k) {
    const auto [e0, g0] = matches[k];
    const auto [e1, g1] = matches[k + delta_frames];
    const SE3 rel_gt = gt.poses[g0].T_wc.inverse() * gt.poses[g1].T_wc;
    const SE3 rel_est = est.poses[e0].T_wc.inverse() * est.poses[e1].T_wc;
    const SE3 e = rel_gt.inverse() * rel_est;
    et.push_back(e.translation().norm());
    er.push_back(e.angle() * kRadToDeg);
  }
  RpeResult r;
  r.pairs = static_cast<int>(et.size());
  const Summary st = summarise(et), sr = summarise(er);
  r.trans_rmse_m = st.rmse;
  r.trans_mean_m = st.mean;
  r.trans_median_m = st.median;
  r.trans_max_m = st.max;
  r.rot_rmse_deg = sr.rmse;
  r.rot_mean_deg = sr.mean;
  r.rot_max_deg = sr.max;
  return r;
}

namespace {
std::string cut_warnings(const Trajectory& gt, const Trajectory& est) {
  std::string w;
  for (const Trajectory* t : {&gt, &est}) {
    if (t->cut_line != 0) w += t->cut_line_warning() + "\n";
    if (t->duplicates != 0) w += t->duplicate_warning() + "\n";
  }
  return w;
}
}  // namespace

Result<AteResult> evaluate_ate_files(const std::string& gt_path, const std::string& est_path, double max_dt) {
  EF_ASSIGN_OR_RETURN(Trajectory gt, read_tum_trajectory(gt_path));
  EF_ASSIGN_OR_RETURN(Trajectory est, read_tum_trajectory(est_path));
  EF_ASSIGN_OR_RETURN(AteResult r, evaluate_ate(gt, est, max_dt));
  r.warnings = cut_warnings(gt, est);
  return r;
}

Result<RpeResult> evaluate_rpe_files(const std::string& gt_path, const std::string& est_path, int delta_frames,
                                     double max_dt) {
  EF_ASSIGN_OR_RETURN(Trajectory gt, read_tum_trajectory(gt_path));
  EF_ASSIGN_OR_RETURN(Trajectory est, read_tum_trajectory(est_path));
  EF_ASSIGN_OR_RETURN(RpeResult r, evaluate_rpe(gt, est, delta_frames, max_dt));
  r.warnings = cut_warnings(gt, est);
  return r;
}

std::string format_ate(const AteResult& r) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "ate_rmse_m %.6f\nate_mean_m %.6f\nate_median_m %.6f\nate_max_m %.6f\npairs %d\n",
                r.rmse_m, r.mean_m, r.median_m, r.max_m, r.pairs);
  return buf;
}

std::string format_rpe(const RpeResult& r) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "rpe_trans_rmse_m %.6f\nrpe_trans_mean_m %.6f\nrpe_trans_median_m %.6f\nrpe_trans_max_m %.6f\n"
                "rpe_rot_rmse_deg %.6f\nrpe_rot_mean_deg %.6f\nrpe_rot_max_deg %.6f\npairs %d\n",
                r.trans_rmse_m, r.trans_mean_m, r.trans_median_m, r.trans_max_m, r.rot_rmse_deg, r.rot_mean_deg,
                r.rot_max_deg, r.pairs);
  return buf;
}

}  // namespace ef
