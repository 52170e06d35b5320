// TUM trajectory writer: format and round trip through the reader.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include "io/trajectory_io.h"
#include "test_support.h"

namespace ef {
namespace {

TEST(OutputsTrajectory, StreamedLinesHaveTumFormat) {
  const std::string path = (test::scratch_dir("traj_fmt") / "est.txt").string();
  TumTrajectoryWriter w;
  EXPECT_FALSE(w.write(0, SE3()).ok());  // not open yet
  ASSERT_TRUE(w.open(path).ok());
  // 120 degrees about (1,1,1), given with qw < 0: written as the equivalent quaternion with qw > 0.
  ASSERT_TRUE(
      w.write(1305031102.175304, SE3(Eigen::Quaterniond(-0.5, -0.5, -0.5, -0.5), Eigen::Vector3d(1.5, -0.25, 2))).ok());
  ASSERT_TRUE(w.write(1305031102.2, SE3()).ok());
  ASSERT_TRUE(w.close().ok());
  ASSERT_TRUE(w.close().ok());  // twice is fine
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(text,
            "# timestamp tx ty tz qx qy qz qw\n"
            "1305031102.175304 1.5 -0.25 2 0.5 0.5 0.5 0.5\n"
            "1305031102.200000 0 0 0 0 0 0 1\n");
}

TEST(OutputsTrajectory, RoundTripKeepsPrecision) {
  std::vector<TimedPose> poses;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.13 * i - 3.0, Eigen::Vector3d(1, 2, -3).normalized()));
    poses.push_back({1305031100.0 + i / 30.0, SE3(q, Eigen::Vector3d(0.123456789 * i, -2.0 / (i + 1), 1e-4 * i))});
  }
  const std::string path = (test::scratch_dir("traj_rt") / "t.txt").string();
  ASSERT_TRUE(write_tum_trajectory(path, poses).ok());
  auto t = read_tum_trajectory(path);
  ASSERT_TRUE(t.ok()) << to_string(t.error());
  ASSERT_EQ(t->poses.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(t->poses[i].timestamp, poses[i].timestamp, 0.6e-6);  // microsecond rounding
    EXPECT_LT((t->poses[i].T_wc.translation() - poses[i].T_wc.translation()).norm(), 1e-8);  // metres
    EXPECT_LT((t->poses[i].T_wc.inverse() * poses[i].T_wc).angle(), 1e-8);                   // radians
  }
}

TEST(OutputsTrajectory, CommentLinesAreSkippedByTheReader) {
  const std::string path = (test::scratch_dir("traj_comment") / "t.txt").string();
  TumTrajectoryWriter w;
  EXPECT_FALSE(w.write_comment("lost 1.0 no_data").ok());  // not open yet
  ASSERT_TRUE(w.open(path).ok());
  ASSERT_TRUE(w.write(1.0, SE3()).ok());
  ASSERT_TRUE(w.write_comment("lost 2.000000 too_few_inliers").ok());
  ASSERT_TRUE(w.write(2.0, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0))).ok());
  ASSERT_TRUE(w.close().ok());
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("\n# lost 2.000000 too_few_inliers\n2.000000 1 0 0"), std::string::npos) << text;
  auto t = read_tum_trajectory(path);
  ASSERT_TRUE(t.ok()) << to_string(t.error());
  ASSERT_EQ(t->poses.size(), 2u);
  EXPECT_EQ(t->poses[1].T_wc.translation().x(), 1.0);
}

TEST(OutputsTrajectory, OpenFailsNamingPath) {
  TumTrajectoryWriter w;
  auto s = w.open("/nonexistent-dir/edgefusion/traj.txt");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("/nonexistent-dir/edgefusion/traj.txt"), std::string::npos);
  EXPECT_FALSE(w.is_open());
}

}  // namespace
}  // namespace ef
