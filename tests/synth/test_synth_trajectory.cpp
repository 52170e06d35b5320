// Trajectories: smooth, realistic speeds, collision-free, looking at geometry, loop revisits.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "synth/synthetic_source.h"
#include "synth/trajectory.h"
#include "test_synth_support.h"

namespace ef {
namespace {

constexpr double kDeg = 3.14159265358979 / 180;

TEST(SynthTrajectory, HandheldLoopIsSmoothAndCollisionFree) {
  for (const std::string& room : synthetic_room_names()) {
    for (uint32_t seed : {0u, 5u}) {
      auto src = test::open_synth("synthetic:" + room + "?frames=1000&size=80x60&seed=" + std::to_string(seed));
      ASSERT_TRUE(src);
      const auto& T = src->poses();
      ASSERT_EQ(T.size(), 1000u);
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
      const double speed = path / (999 / 30.0);
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

TEST(SynthTrajectory, ViewsContainGeometryAtSensorRange) {
  // Median depth between 0.8 and 4.5 m on every 10th frame, and most of the noisy depth valid.
  for (const std::string& room : synthetic_room_names()) {
    for (const char* traj : {"loop", "robot"}) {
      auto src = test::open_synth("synthetic:" + room + "?size=80x60&trajectory=" + std::string(traj));
      ASSERT_TRUE(src);
      Frame f;
      for (int64_t i = 0; i < 300; i += 10) {
        ASSERT_TRUE(src->render(i, f).ok());
        std::vector<float> z;
        for (std::size_t p = 0; p < f.depth.size(); ++p)
          if (f.depth.data()[p] > 0) z.push_back(f.depth.data()[p]);
        ASSERT_GT(z.size(), f.depth.size() * 4 / 10) << room << " " << traj << " frame " << i;
        std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
        EXPECT_GT(z[z.size() / 2], 0.8f) << room << " " << traj << " frame " << i;
        EXPECT_LT(z[z.size() / 2], 4.5f) << room << " " << traj << " frame " << i;
      }
    }
  }
}

}  // namespace
}  // namespace ef
