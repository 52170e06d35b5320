// ATE / RPE against analytically known answers, and the TUM trajectory reader's error reports.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "eval/trajectory_eval.h"
#include "io/trajectory_io.h"
#include "test_support.h"

namespace ef {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A non-planar path (a helix with a vertical wobble), rotations varying with i; metres, seconds.
Eigen::Vector3d path_point(int k) {
  const double a = 0.3 * k;
  return Eigen::Vector3d(1.5 * std::cos(a), 1.0 * std::sin(a), 0.05 * k + 0.2 * std::sin(1.7 * a));
}
SE3 path_pose(int k, const Eigen::Vector3d& p) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
  return SE3(q, p);
}

Trajectory helix(int n, double t0 = 100.0, double dt = 1.0 / 30) {
  Trajectory t;
  t.source = "gt";
  for (int i = 0; i < n; ++i) t.poses.push_back({t0 + i * dt, path_pose(i, path_point(i))});
  return t;
}

SE3 some_rigid_transform() {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())),
             Eigen::Vector3d(3.0, -1.0, 0.25));
}

TEST(Ate, SelfIsZero) {
  const Trajectory gt = helix(60);
  auto r = evaluate_ate(gt, gt, 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->pairs, 60);
  EXPECT_LT(r->rmse_m, 1e-12);
  EXPECT_LT(r->max_m, 1e-12);
  EXPECT_NEAR(r->T_gt_est.translation().norm(), 0.0, 1e-12);
  EXPECT_NEAR(r->T_gt_est.angle(), 0.0, 1e-9);
}

TEST(Ate, RigidlyMovedCopyAlignsToZero) {
  const Trajectory gt = helix(50);
  const SE3 T = some_rigid_transform();
  Trajectory est = gt;
  est.source = "est";
  for (auto& p : est.poses) p.T_wc = T * p.T_wc;
  auto r = evaluate_ate(gt, est, 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->pairs, 50);
  EXPECT_LT(r->rmse_m, 1e-9);
  // The alignment found is the inverse of the applied transform.
  const SE3 d = r->T_gt_est * T;
  EXPECT_LT(d.translation().norm(), 1e-9);
  EXPECT_LT(d.angle(), 1e-9);
}

// Poses come in groups of four at the same position; the four estimates are offset by +a z, -a z,
// +b x, -b x. The offsets sum to zero within each group, so they are uncorrelated with the
// positions: the optimal alignment is the identity and every error is exactly a or b.
// RMSE = sqrt((a^2 + b^2) / 2), mean = median = (a + b) / 2, max = b.
Trajectory grouped_truth(int groups) {
  Trajectory gt;
  gt.source = "gt";
  int i = 0;
  for (int g = 0; g < groups; ++g)
    for (int k = 0; k < 4; ++k, ++i) gt.poses.push_back({10.0 + 0.1 * i, path_pose(i, path_point(g))});
  return gt;
}

Trajectory offset_estimate(const Trajectory& gt, double a, double b, const SE3& T) {
  const Eigen::Vector3d offsets[4] = {{0, 0, a}, {0, 0, -a}, {b, 0, 0}, {-b, 0, 0}};
  Trajectory est = gt;
  est.source = "est";
  for (std::size_t i = 0; i < est.poses.size(); ++i) {
    const SE3& P = gt.poses[i].T_wc;
    est.poses[i].T_wc = T * SE3(P.rotation(), P.translation() + offsets[i % 4]);
  }
  return est;
}

TEST(Ate, KnownOffsetsGiveAnalyticRmse) {
  const Trajectory gt = grouped_truth(20);
  const double a = 0.01, b = 0.03;  // metres
  auto r = evaluate_ate(gt, offset_estimate(gt, a, b, SE3()), 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->pairs, 80);
  EXPECT_NEAR(r->rmse_m, std::sqrt(0.0005), 1e-10);  // sqrt((1e-4 + 9e-4) / 2)
  EXPECT_NEAR(r->mean_m, 0.02, 1e-10);
  EXPECT_NEAR(r->median_m, 0.02, 1e-10);
  EXPECT_NEAR(r->max_m, 0.03, 1e-10);
}

TEST(Ate, KnownOffsetsUnderRigidMotion) {
  const Trajectory gt = grouped_truth(15);
  auto r = evaluate_ate(gt, offset_estimate(gt, 0.01, 0.01, some_rigid_transform()), 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_NEAR(r->rmse_m, 0.01, 1e-9);  // every error is exactly 1 cm
  EXPECT_NEAR(r->max_m, 0.01, 1e-9);
}

TEST(Ate, TimestampShiftWithinMaxDt) {
  const Trajectory gt = helix(40, 5.0, 0.1);
  Trajectory est = gt;
  est.source = "est";
  for (auto& p : est.poses) p.timestamp += 0.015;  // seconds
  auto r = evaluate_ate(gt, est, 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->pairs, 40);
  EXPECT_LT(r->rmse_m, 1e-9);
  auto none = evaluate_ate(gt, est, 0.01);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("only 0 poses associated"), std::string::npos) << none.error().message;
  EXPECT_NE(none.error().message.find("'gt'"), std::string::npos);
  EXPECT_NE(none.error().message.find("'est'"), std::string::npos);
}

TEST(Ate, SubsampledEstimateUsesOnlyMatchedPoses) {
  const Trajectory gt = helix(90, 0.0, 0.01);
  Trajectory est;
  est.source = "est";
  for (std::size_t i = 0; i < gt.poses.size(); i += 3) est.poses.push_back(gt.poses[i]);
  auto r = evaluate_ate(gt, est, 0.004);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->pairs, 30);
  EXPECT_LT(r->rmse_m, 1e-12);
}

TEST(Associate, GreedyOneToOneByTimeDifference) {
  auto mk = [](std::initializer_list<double> ts) {
    std::vector<TimedPose> v;
    for (double t : ts) v.push_back({t, SE3()});
    return v;
  };
  // a0 has candidates b0 (5 ms) and b1 (12 ms); a1 matches b2 exactly; a2 has none within 20 ms.
  auto m = associate_timestamps(mk({0.0, 0.1, 0.2}), mk({0.005, 0.012, 0.1, 0.3}), 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(0, 0));
  EXPECT_EQ(m[1], std::make_pair(1, 2));
  // One b for two a: the closer a (4 ms against 6 ms) takes it.
  auto m2 = associate_timestamps(mk({0.0, 0.01}), mk({0.006}), 0.02);
  ASSERT_EQ(m2.size(), 1u);
  EXPECT_EQ(m2[0], std::make_pair(1, 0));
}

TEST(Ate, TooFewPairsNamesFiles) {
  const auto dir = test::scratch_dir("ate_few");
  const std::string g = (dir / "gt.txt").string(), e = (dir / "est.txt").string();
  ASSERT_TRUE(write_tum_trajectory(g, helix(2).poses).ok());
  ASSERT_TRUE(write_tum_trajectory(e, helix(2).poses).ok());
  auto r = evaluate_ate_files(g, e, 0.02);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(g), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(e), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("need at least 3"), std::string::npos) << r.error().message;
}

TEST(Ate, FilesAgainstThemselvesPrintZero) {
  const auto dir = test::scratch_dir("ate_files");
  const std::string g = (dir / "gt.txt").string();
  ASSERT_TRUE(write_tum_trajectory(g, helix(30).poses).ok());
  auto r = evaluate_ate_files(g, g, 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_LT(r->rmse_m, 1e-7);  // file precision: 9 significant digits
  const std::string text = format_ate(*r);
  EXPECT_NE(text.find("ate_rmse_m 0.000000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("pairs 30\n"), std::string::npos) << text;
}

// Ground truth moves 0.1 m along x per frame; the estimate 0.11 m: every relative translation over
// d frames is off by 0.01 * d metres.
TEST(Rpe, TranslationalDrift) {
  Trajectory gt, est;
  gt.source = "gt";
  est.source = "est";
  for (int i = 0; i < 21; ++i) {
    gt.poses.push_back({1.0 + i * 0.1, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * i, 0, 0))});
    est.poses.push_back({1.0 + i * 0.1, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.11 * i, 0, 0))});
  }
  auto r1 = evaluate_rpe(gt, est, 1, 0.02);
  ASSERT_TRUE(r1.ok()) << to_string(r1.error());
  EXPECT_EQ(r1->pairs, 20);
  EXPECT_NEAR(r1->trans_rmse_m, 0.01, 1e-12);
  EXPECT_NEAR(r1->trans_max_m, 0.01, 1e-12);
  EXPECT_NEAR(r1->rot_rmse_deg, 0.0, 1e-9);
  auto r5 = evaluate_rpe(gt, est, 5, 0.02);
  ASSERT_TRUE(r5.ok());
  EXPECT_EQ(r5->pairs, 16);
  EXPECT_NEAR(r5->trans_rmse_m, 0.05, 1e-12);
}

// The estimate turns 1 degree per frame about z while the truth stands still.
TEST(Rpe, RotationalDrift) {
  Trajectory gt, est;
  gt.source = "gt";
  est.source = "est";
  for (int i = 0; i < 10; ++i) {
    gt.poses.push_back({i * 1.0, SE3()});
    est.poses.push_back({i * 1.0, SE3(Eigen::Quaterniond(Eigen::AngleAxisd(i * kPi / 180, Eigen::Vector3d::UnitZ())),
                                      Eigen::Vector3d::Zero())});
  }
  auto r = evaluate_rpe(gt, est, 2, 0.02);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->pairs, 8);
  EXPECT_NEAR(r->rot_rmse_deg, 2.0, 1e-9);
  EXPECT_NEAR(r->rot_max_deg, 2.0, 1e-9);
  EXPECT_NEAR(r->trans_rmse_m, 0.0, 1e-12);
}

TEST(Rpe, RigidlyMovedCopyIsZeroAndErrors) {
  const Trajectory gt = helix(30);
  Trajectory est = gt;
  est.source = "est";
  for (auto& p : est.poses) p.T_wc = some_rigid_transform() * p.T_wc;
  auto r = evaluate_rpe(gt, est, 3, 0.02);
  ASSERT_TRUE(r.ok());
  EXPECT_LT(r->trans_rmse_m, 1e-9);
  EXPECT_LT(r->rot_rmse_deg, 1e-6);
  EXPECT_FALSE(evaluate_rpe(gt, est, 0, 0.02).ok());
  auto too_long = evaluate_rpe(gt, est, 30, 0.02);
  ASSERT_FALSE(too_long.ok());
  EXPECT_NE(too_long.error().message.find("30 poses associated"), std::string::npos) << too_long.error().message;
}

// --- TUM reader -------------------------------------------------------------------------------

std::string write_text(const std::string& test, const std::string& text) {
  const auto path = (test::scratch_dir(test) / "traj.txt").string();
  std::ofstream(path) << text;
  return path;
}

TEST(TumReader, CommentsBlankLinesAndNormalisation) {
  const std::string p = write_text("tum_ok",
                                   "# ground truth\n\n"
                                   "1.0 1 2 3 0 0 0 2\n"
                                   "  # indented comment\n"
                                   "1.5 4 5 6 0 0 1 0\r\n");
  auto t = read_tum_trajectory(p);
  ASSERT_TRUE(t.ok()) << to_string(t.error());
  ASSERT_EQ(t->poses.size(), 2u);
  EXPECT_EQ(t->source, p);
  EXPECT_DOUBLE_EQ(t->poses[0].timestamp, 1.0);
  EXPECT_DOUBLE_EQ(t->poses[0].T_wc.translation().y(), 2.0);
  EXPECT_NEAR(t->poses[0].T_wc.rotation().w(), 1.0, 1e-15);  // (0,0,0,2) normalised
  EXPECT_NEAR(t->poses[1].T_wc.angle(), kPi, 1e-12);          // 180 degrees about z
}

// `edgefusion run` marks a lost frame with "# lost <timestamp> <reason>" just before its pose line.
TEST(TumReader, LostMarkFlagsTheNextPoseOnly) {
  const std::string p = write_text("tum_lost",
                                   "# timestamp tx ty tz qx qy qz qw\n"
                                   "1.000000 0 0 0 0 0 0 1\n"
                                   "# lost 2.000000 too_few_points\n"
                                   "2.000000 0 0 0 0 0 0 1\n"
                                   "# lost-like comment\n"
                                   "3.000000 0 0 0 0 0 0 1\n");
  auto t = read_tum_trajectory(p);
  ASSERT_TRUE(t.ok()) << to_string(t.error());
  ASSERT_EQ(t->poses.size(), 3u);
  EXPECT_FALSE(t->poses[0].lost);
  EXPECT_TRUE(t->poses[1].lost);
  EXPECT_FALSE(t->poses[2].lost);
}

void expect_error_at(const std::string& text, const std::string& test, const std::string& line_and_fault) {
  const std::string p = write_text(test, text);
  auto t = read_tum_trajectory(p);
  ASSERT_FALSE(t.ok()) << test;
  EXPECT_EQ(t.error().code, ErrorCode::kCorruptData);
  EXPECT_NE(t.error().message.find(p + ":" + line_and_fault), std::string::npos) << t.error().message;
}

// A repeated timestamp (TUM fr2/desk's ground truth has one): the later pose replaces the earlier,
// as the TUM tools keep the last, counted and named; the evaluators pass the warning on (issue 33,
// rough edge 8: `eval ate` refused the file).
TEST(TumReader, ARepeatedTimestampKeepsTheLaterPose) {
  const std::string p = write_text("tum_equal", "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n2 5 0 0 0 0 0 1\n3 0 0 0 0 0 0 1\n"
                                                "3 0 7 0 0 0 0 1\n");
  auto t = read_tum_trajectory(p);
  ASSERT_TRUE(t.ok()) << to_string(t.error());
  ASSERT_EQ(t->poses.size(), 3u);
  EXPECT_EQ(t->poses[1].T_wc.translation().x(), 5.0);
  EXPECT_EQ(t->poses[2].T_wc.translation().y(), 7.0);
  EXPECT_EQ(t->duplicates, 2);
  EXPECT_EQ(t->first_duplicate_line, 3);
  EXPECT_NE(t->duplicate_warning().find(p + ":3: 2 pose lines repeat"), std::string::npos) << t->duplicate_warning();
  auto ate = evaluate_ate_files(p, p);
  ASSERT_TRUE(ate.ok()) << to_string(ate.error());
  EXPECT_EQ(ate->pairs, 3);
  EXPECT_NE(ate->warnings.find("repeat the previous line's timestamp"), std::string::npos) << ate->warnings;
}

TEST(TumReader, RejectsBadInputNamingFileAndLine) {
  expect_error_at("# c\n1 0 0 0 0 0 0 1\n2 0 zero 0 0 0 0 1\n", "tum_garbage", "3: field 3 (ty) 'zero'");
  expect_error_at("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n", "tum_fields7", "2: expected 8 fields");
  expect_error_at("1 0 0 0 0 0 0 1 9\n", "tum_fields9", "1: expected 8 fields");
  expect_error_at("2 0 0 0 0 0 0 1\n\n1 0 0 0 0 0 0 1\n", "tum_backwards", "3: timestamp 1.000000 is before");
  expect_error_at("1 0 0 0 0 0 0 0\n", "tum_zeroq", "1: zero quaternion");
  expect_error_at("1 0 0 nan 0 0 0 1\n", "tum_nan", "1: field 4 (tz) 'nan' is not a finite number");
  expect_error_at("1 0 0 1e999 0 0 0 1\n", "tum_inf", "1: field 4");
  expect_error_at("1 0 0 1.5x 0 0 0 1\n", "tum_suffix", "1: field 4");
}

TEST(TumReader, MissingFile) {
  auto t = read_tum_trajectory("/nonexistent/edgefusion/traj.txt");
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kNotFound);
  EXPECT_NE(t.error().message.find("/nonexistent/edgefusion/traj.txt"), std::string::npos);
}

}  // namespace
}  // namespace ef
