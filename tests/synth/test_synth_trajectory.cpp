// Trajectories: smooth, realistic speeds, collision-free, looking at geometry, loop revisits.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "synth/synthetic_source.h"
#include "synth/trajectory.h"
#include "test_support.h"
#include "test_synth_support.h"

namespace ef {
namespace {

constexpr double kDeg = 3.14159265358979 / 180;

// Both hand-held kinds (the inspecting scan walks the loop's path, turning more).
class HandheldPath : public ::testing::TestWithParam<const char*> {};
INSTANTIATE_TEST_SUITE_P(SynthTrajectory, HandheldPath, ::testing::Values("loop", "inspect"));

TEST_P(HandheldPath, IsSmoothAndCollisionFree) {
  // The scan turns half round about 2.4 times a lap at the turn limit, so its lap takes longer:
  // 1300 frames for the revisit below.
  const int frames = std::string(GetParam()) == "loop" ? 1000 : 1300;
  for (const std::string& room : synthetic_room_names()) {
    for (uint32_t seed : {0u, 5u}) {
      auto src = test::open_synth("synthetic:" + room + "?frames=" + std::to_string(frames) +
                                  "&size=80x60&trajectory=" + GetParam() + "&seed=" + std::to_string(seed));
      ASSERT_TRUE(src);
      const auto& T = src->poses();
      ASSERT_EQ(T.size(), static_cast<std::size_t>(frames));
      double max_step = 0, max_turn = 0, min_step = 1, path = 0;
      for (std::size_t i = 1; i < T.size(); ++i) {
        const double step = (T[i].translation() - T[i - 1].translation()).norm();
        max_step = std::max(max_step, step);
        min_step = std::min(min_step, step);
        path += step;
        max_turn = std::max(max_turn, (T[i - 1].inverse() * T[i]).angle());
        // Smooth: acceleration (second difference) below 1.5 mm per frame^2.
        if (i >= 2) {
          const Eigen::Vector3d acc = T[i].translation() - 2 * T[i - 1].translation() + T[i - 2].translation();
          ASSERT_LT(acc.norm(), 1.5e-3) << room << " frame " << i;
        }
        ASSERT_GT(src->scene().free_space_distance(T[i].translation().cast<float>()), 0.25f) << room << " frame " << i;
      }
      EXPECT_LE(max_step, 0.03) << room;
      EXPECT_LE(max_turn, 2.0 * kDeg) << room;
      const double speed = path / ((frames - 1) / 30.0);
      EXPECT_GE(speed, 0.2) << room;
      EXPECT_LE(speed, 1.0) << room;
      // Revisit: a frame at least 10 s after frame j comes back within 0.3 m of it.
      bool revisit = false;
      for (std::size_t j = 0; j < 300 && !revisit; j += 10)
        for (std::size_t k = j + 300; k < T.size() && !revisit; ++k)
          revisit = (T[k].translation() - T[j].translation()).norm() < 0.3;
      EXPECT_TRUE(revisit) << room;
    }
  }
}

TEST(SynthTrajectory, RobotPathIsPlanarLevelAndClear) {
  for (const std::string& room : synthetic_room_names()) {
    auto src = test::open_synth("synthetic:" + room + "?trajectory=robot&frames=600&size=80x60&seed=3");
    ASSERT_TRUE(src);
    const auto& T = src->poses();
    const double z0 = T[0].translation().z();
    EXPECT_GE(z0, 0.3);
    EXPECT_LE(z0, 0.6);
    for (std::size_t i = 1; i < T.size(); ++i) {
      EXPECT_NEAR(T[i].translation().z(), z0, 1e-9);
      // Level: the camera's y axis (down) is the world's -z.
      EXPECT_NEAR(T[i].rotation_matrix().col(1).z(), -1.0, 1e-6);
      EXPECT_LE((T[i].translation() - T[i - 1].translation()).norm(), synth::kRobotSpeed / 30 + 1e-4);
      EXPECT_LE((T[i - 1].inverse() * T[i]).angle(), synth::kRobotTurn / 30 + 1e-4);
      ASSERT_GT(src->scene().floor_clearance(T[i].translation().cast<float>(), 0.9f), 0.29f) << room << " frame " << i;
    }
  }
}

// Median of v (the upper one of an even count; 0 when empty).
float median_of(std::vector<float> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Median of the measured (non-zero) depths of a frame, metres (0 when none), and their count.
float median_valid_depth(const Frame& f, std::size_t* valid = nullptr) {
  std::vector<float> z;
  for (std::size_t p = 0; p < f.depth.size(); ++p)
    if (f.depth.data()[p] > 0) z.push_back(f.depth.data()[p]);
  if (valid != nullptr) *valid = z.size();
  return median_of(std::move(z));
}

TEST(SynthTrajectory, ViewsContainGeometryAtSensorRange) {
  // Median depth between 0.8 (the inspecting scan's close views: 0.55) and 4.5 m on every 10th
  // frame, and most of the noisy depth valid.
  for (const std::string& room : synthetic_room_names()) {
    for (const char* traj : {"loop", "robot", "inspect"}) {
      auto src = test::open_synth("synthetic:" + room + "?size=80x60&trajectory=" + std::string(traj));
      ASSERT_TRUE(src);
      Frame f;
      for (int64_t i = 0; i < 300; i += 10) {
        ASSERT_TRUE(src->render(i, f).ok());
        std::size_t valid = 0;
        const float median = median_valid_depth(f, &valid);
        ASSERT_GT(valid, f.depth.size() * 4 / 10) << room << " " << traj << " frame " << i;
        EXPECT_GT(median, std::string(traj) == "inspect" ? 0.55f : 0.8f) << room << " " << traj << " frame " << i;
        EXPECT_LT(median, 4.5f) << room << " " << traj << " frame " << i;
      }
    }
  }
}

// Fraction of the poses whose optical axis points away from the room's middle (horizontally),
// and the median depth of the rendered frames (every 10th) looking away and looking towards it.
struct GazeSplit {
  double outward_fraction = 0;
  float median_depth_out = 0, median_depth_in = 0;
};

GazeSplit gaze_split(synth::SyntheticSource& src) {
  const Eigen::Vector3d centre(src.scene().size.x() / 2, src.scene().size.y() / 2, 0);
  const auto& T = src.poses();
  std::vector<float> depth_out, depth_in;
  int outward = 0;
  Frame f;
  for (std::size_t i = 0; i < T.size(); ++i) {
    const Eigen::Vector3d forward = T[i].rotation_matrix().col(2);
    const Eigen::Vector3d to_middle = centre - T[i].translation();
    const bool out = forward.x() * to_middle.x() + forward.y() * to_middle.y() < 0;
    outward += out;
    if (i % 10 != 0) continue;
    EXPECT_TRUE(src.render(static_cast<int64_t>(i), f).ok());
    (out ? depth_out : depth_in).push_back(median_valid_depth(f));
  }
  return {static_cast<double>(outward) / static_cast<double>(T.size()), median_of(depth_out), median_of(depth_in)};
}

TEST(SynthTrajectory, InspectWalksTheLoopAndLooksAcrossAndClose) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  for (const std::string& room : synthetic_room_names()) {
    const std::string what = "synthetic:" + room;
    auto loop = test::open_synth(what + "?frames=1200&size=80x60&seed=3&noise=0");
    auto inspect = test::open_synth(what + "?frames=1200&size=80x60&seed=3&noise=0&trajectory=inspect");
    ASSERT_TRUE(loop && inspect);
    // The same path through the room: one lap of each, position for position.
    synth::TrajectoryOptions t;
    t.seed = 3;
    const auto lap_loop = synth::trajectory_lap(loop->scene(), t);
    t.kind = synth::TrajectoryKind::kInspect;
    const auto lap_inspect = synth::trajectory_lap(inspect->scene(), t);
    ASSERT_TRUE(lap_loop.ok() && lap_inspect.ok());
    ASSERT_EQ(lap_loop->size(), lap_inspect->size());
    for (std::size_t k = 0; k < lap_loop->size(); ++k) ASSERT_EQ((*lap_loop)[k], (*lap_inspect)[k]) << what << " " << k;
    // The loop looks across the middle; the scan spends a real part of the time facing the near
    // wall, and sees it from close by.
    const GazeSplit a = gaze_split(*loop), b = gaze_split(*inspect);
    std::printf("%s: looking away from the middle: loop %.1f%%, inspect %.1f%%; median depth inspect %.2f m away, "
                "%.2f m towards\n", room.c_str(), 100 * a.outward_fraction, 100 * b.outward_fraction,
                b.median_depth_out, b.median_depth_in);
    EXPECT_LT(a.outward_fraction, 0.05) << what;
    EXPECT_GT(b.outward_fraction, 0.25) << what;
    EXPECT_LT(b.outward_fraction, 0.75) << what;
    EXPECT_LT(b.median_depth_out, 0.75f * b.median_depth_in) << what;
  }
}

}  // namespace
}  // namespace ef
