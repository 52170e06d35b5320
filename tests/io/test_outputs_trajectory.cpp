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


// A loop closure's rewrite (pipeline/mapping_stage.h): the pose lines it has corrections for are
// written again, everything else stays byte for byte, a second rewrite replaces the first's comment.
TEST(OutputsTrajectory, RewriteReplacesCorrectedPosesAndKeepsEverythingElse) {
  const std::string path = (test::scratch_dir("traj_rewrite") / "t.txt").string();
  TumTrajectoryWriter w;
  ASSERT_TRUE(w.open(path).ok());
  for (int i = 0; i < 6; ++i) {
    if (i == 2) {
      ASSERT_TRUE(w.write_comment("lost 0.066667 diverged").ok());
    }
    ASSERT_TRUE(w.write(i / 30.0, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * i, 0, 1))).ok());
  }
  ASSERT_TRUE(w.close().ok());
  // Frames 3.. moved by 5 cm along y; frames 0-2 unknown to the corrector.
  auto correct = [](double t, SE3* T) {
    if (t < 0.09) return false;
    *T = SE3(T->rotation(), T->translation() + Eigen::Vector3d(0, 0.05, 0));
    return true;
  };
  auto r = rewrite_tum_poses(path, correct, "poses corrected: first", 15);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->corrected, 3);
  EXPECT_EQ(r->kept, 3);
  auto read = read_tum_trajectory(path);
  ASSERT_TRUE(read.ok()) << to_string(read.error());
  ASSERT_EQ(read->poses.size(), 6u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(read->poses[i].T_wc.translation().y(), i >= 3 ? 0.05 : 0.0, 1e-9) << i;
    EXPECT_NEAR(read->poses[i].T_wc.translation().x(), 0.1 * i, 1e-9) << i;
    EXPECT_EQ(read->poses[i].lost, i == 2) << i;  // the "# lost" mark still marks its line
  }
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(static_cast<int64_t>(text.size()), r->bytes);
  EXPECT_EQ(text.rfind("# timestamp tx ty tz qx qy qz qw\n# poses corrected: first\n", 0), 0u) << text;
  EXPECT_NE(text.find("0.033333 0.1 0 1 0 0 0 1\n"), std::string::npos) << "an uncorrected line changed:\n" << text;
  // Again: the earlier comment (same first 15 bytes) is replaced, not repeated.
  auto again = rewrite_tum_poses(path, [](double, SE3*) { return false; }, "poses corrected: second", 15);
  ASSERT_TRUE(again.ok());
  std::ifstream in2(path);
  text.assign((std::istreambuf_iterator<char>(in2)), {});
  EXPECT_EQ(text.find("first"), std::string::npos) << text;
  EXPECT_NE(text.find("# poses corrected: second\n"), std::string::npos) << text;
  // A file that is not a trajectory is left alone, the error naming the line.
  {
    std::ofstream bad(path, std::ios::app);
    bad << "1.0 2.0 three\n";
  }
  auto failed = rewrite_tum_poses(path, correct, "x", 1);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.error().message.find(path + ":10:"), std::string::npos) << failed.error().message;
  EXPECT_FALSE(rewrite_tum_poses(path + ".missing", correct).ok());
}

// fuzz_trajectory's finding (issue 34): the reproducer below, minimised. A corrected line was
// written with its timestamp rounded to microseconds; where a later line kept a timestamp written
// with more digits (here a repeat of the same instant, which replaces the pose before it), the
// rounded one fell after it, and the rewritten file no longer read ("timestamp ... is before the
// previous one"). Now each line keeps its timestamp as written, and a repeated line is corrected too.
TEST(OutputsTrajectory, RewriteKeepsTimestampsAsWrittenSoTheFileStillReads) {
  const std::string path = (test::scratch_dir("traj_rewrite_stamps") / "t.txt").string();
  {
    std::ofstream out(path, std::ios::binary);
    out << "#7 2.67282367 1.46081515\n"
           "# lost 0.033333 too few in61\x01\n"
           "2.6728236675262451 1.4618151574111116 0.43963762605913126 0.57946207342 -0.443458687 -0.5767881 "
           "0.522504547 0.44457719147028\n"
           "# lost 0.033333 too few in61\x01\n"
           "2.6728236675262451 1.4618151574111116 0.43963762605913126 0.57946207342 -0.443458687 -0.5767881 "
           "0.522504547 0.444577191\n"
           "2.7 0 0 0 0 0 0 1\n";
  }
  int calls = 0;
  auto shift = [&calls](double, SE3* T) {
    ++calls;
    *T = SE3(T->rotation(), T->translation() + Eigen::Vector3d(0.01, 0, 0));
    return true;
  };
  auto r = rewrite_tum_poses(path, shift, "loop closure: test", 13);
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(calls, 3);  // the repeated line is a pose line as well
  EXPECT_EQ(r->corrected, 3);
  auto read = read_tum_trajectory(path);
  ASSERT_TRUE(read.ok()) << to_string(read.error());
  ASSERT_EQ(read->poses.size(), 2u);
  EXPECT_EQ(read->duplicates, 1);
  EXPECT_EQ(read->poses[0].timestamp, 2.6728236675262451);  // the instant as written, not 2.672824
  EXPECT_NEAR(read->poses[0].T_wc.translation().x(), 1.4718151574111116, 1e-8);
  EXPECT_TRUE(read->poses[0].lost);
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("\n2.6728236675262451 1.47181516 "), std::string::npos) << text;
  // And again: a rewritten file can always be rewritten.
  auto again = rewrite_tum_poses(path, shift, "loop closure: again", 13);
  ASSERT_TRUE(again.ok()) << to_string(again.error());
  EXPECT_TRUE(read_tum_trajectory(path).ok());
}

// fuzz_trajectory's second finding (issue 34), the line of its reproducer: a quaternion component of
// 4.4e190 squared overflows the norm to infinity, which passed the zero check; normalised, the pose
// had a NaN rotation (a rewrite then wrote "nan" and the file no longer read). Now the line is refused.
TEST(OutputsTrajectory, AQuaternionWhoseNormOverflowsIsRefusedNamingTheLine) {
  const std::string path = (test::scratch_dir("traj_overflow") / "t.txt").string();
  {
    std::ofstream out(path, std::ios::binary);
    out << "# timestamp tx ty tz qx qy qz qw\n"
           "1.0 0 0 0 0 0 0 1\n"
           "2.6728236675262451 1.4618151574111116 0.43963762605913126 0.57946207342 -0.443458687 -0.5767881 "
           "0.522504547 0.44457e191\n";
  }
  auto t = read_tum_trajectory(path);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kCorruptData);
  EXPECT_NE(t.error().message.find(path + ":3: quaternion too large to normalise"), std::string::npos)
      << t.error().message;
  // Large but finite norms are still taken and normalised, as before.
  {
    std::ofstream out(path, std::ios::binary);
    out << "3.0 0 0 0 0 0 0 1e150\n";
  }
  auto big = read_tum_trajectory(path);
  ASSERT_TRUE(big.ok()) << to_string(big.error());
  EXPECT_NEAR(big->poses[0].T_wc.rotation().w(), 1.0, 1e-12);
}

}  // namespace
}  // namespace ef
