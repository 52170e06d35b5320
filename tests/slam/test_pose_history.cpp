// The pose history loop closure corrects (slam/pose_history.h): its ring, its lookups, its
// checkpoint form, and a deformation moving every held pose as the graph moves a camera.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "slam/deformation_graph.h"
#include "slam/pose_history.h"
#include "support/alloc_counter.h"

namespace ef::slam {
namespace {

SE3 pose_at(int f) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.002 * f, Eigen::Vector3d::UnitY())),
             Eigen::Vector3d(0.01 * f, 0.3 * std::sin(0.02 * f), 0.0));
}
double stamp(int f) { return 1305031100.0 + f / 30.0; }

TEST(PoseHistory, KeepsTheNewestFramesAndFindsThemByFrameAndTime) {
  auto h = PoseHistory::create(50);
  ASSERT_TRUE(h.ok());
  for (int f = 0; f < 120; ++f) h->push(f, stamp(f), pose_at(f));
  EXPECT_EQ(h->size(), 50);
  EXPECT_EQ(h->first_frame(), 70);
  EXPECT_EQ(h->overwritten(), 70);
  SE3 T;
  EXPECT_FALSE(h->at_frame(69, &T));
  EXPECT_FALSE(h->at_frame(120, &T));
  ASSERT_TRUE(h->at_frame(100, &T));
  EXPECT_LT((T.translation() - pose_at(100).translation()).norm(), 1e-15);
  // By timestamp, as trajectory.txt writes it (6 decimals).
  ASSERT_TRUE(h->at_time(std::round(stamp(90) * 1e6) / 1e6, &T));
  EXPECT_LT((T.translation() - pose_at(90).translation()).norm(), 1e-15);
  EXPECT_FALSE(h->at_time(stamp(90) + 0.01, &T));  // between frames
  EXPECT_FALSE(h->at_time(stamp(10), &T));         // overwritten
  // A frame that is not the next one starts again.
  h->push(500, stamp(500), pose_at(500));
  EXPECT_EQ(h->size(), 1);
  EXPECT_FALSE(h->at_frame(100, &T));
  EXPECT_TRUE(h->at_frame(500, &T));
  // Capacity 0 keeps nothing.
  auto none = PoseHistory::create(0);
  ASSERT_TRUE(none.ok());
  none->push(0, 0.0, SE3());
  EXPECT_EQ(none->size(), 0);
  EXPECT_EQ(none->bytes(), 0u);
  EXPECT_FALSE(PoseHistory::create(-1).ok());
}

TEST(PoseHistory, RunsRestoreTheSameRing) {
  auto h = PoseHistory::create(40);
  ASSERT_TRUE(h.ok());
  for (int f = 0; f < 95; ++f) h->push(f, stamp(f), pose_at(f));
  const double* data[2];
  int64_t records[2];
  const int n = h->runs(data, records);
  ASSERT_EQ(n, 2);  // 95 % 40 != 0: the ring wraps
  std::vector<double> flat;
  for (int i = 0; i < n; ++i) flat.insert(flat.end(), data[i], data[i] + records[i] * PoseHistory::kWords);
  ASSERT_EQ(flat.size(), 40u * PoseHistory::kWords);
  auto back = PoseHistory::create(40);
  ASSERT_TRUE(back.ok());
  ASSERT_TRUE(back->restore(h->first_frame(), h->size(), h->overwritten(), 3, flat.data()).ok());
  EXPECT_EQ(back->first_frame(), 55);
  EXPECT_EQ(back->overwritten(), 55);
  EXPECT_EQ(back->deformations(), 3);
  for (int f = 55; f < 95; ++f) {
    SE3 a, b;
    ASSERT_TRUE(h->at_frame(f, &a) && back->at_frame(f, &b)) << f;
    EXPECT_EQ(a.translation(), b.translation()) << f;
    EXPECT_EQ(a.rotation().coeffs(), b.rotation().coeffs()) << f;
  }
  // The next frame continues the restored ring.
  back->push(95, stamp(95), pose_at(95));
  EXPECT_EQ(back->first_frame(), 56);
  // A smaller history keeps the newest.
  auto small = PoseHistory::create(10);
  ASSERT_TRUE(small.ok());
  ASSERT_TRUE(small->restore(55, 40, 55, 0, flat.data()).ok());
  EXPECT_EQ(small->first_frame(), 85);
  EXPECT_EQ(small->overwritten(), 85);
  // Records that are not poses, or times that go back: corrupt.
  std::vector<double> bad = flat;
  bad[5 * PoseHistory::kWords + 7] = 2.0;  // |q| != 1
  EXPECT_EQ(back->restore(55, 40, 55, 0, bad.data()).error().code, ErrorCode::kCorruptData);
  bad = flat;
  bad[6 * PoseHistory::kWords] = 0.0;  // timestamp
  EXPECT_EQ(back->restore(55, 40, 55, 0, bad.data()).error().code, ErrorCode::kCorruptData);
  EXPECT_EQ(back->restore(5, 40, 55, 0, flat.data()).error().code, ErrorCode::kCorruptData);
}

TEST(PoseHistory, ADeformationMovesEveryHeldPoseAsTheGraphMovesACamera) {
  // A path along x with one node every 10 frames; its end bent 10 cm along y.
  std::vector<Eigen::Vector3f> nodes;
  std::vector<int32_t> times;
  for (int f = 0; f < 300; f += 10) {
    nodes.push_back((pose_at(f) * Eigen::Vector3d(0, 0, 1)).cast<float>());
    times.push_back(f);
  }
  auto g = DeformationGraph::create({});
  ASSERT_TRUE(g.ok());
  ASSERT_TRUE(g->build(nodes.data(), times.data(), static_cast<int32_t>(nodes.size())).ok());
  const Eigen::Vector3f shift(0.0f, 0.10f, 0.0f);
  for (int f = 0; f < 60; f += 3) {
    const Eigen::Vector3f p = (pose_at(f) * Eigen::Vector3d(0, 0, 1)).cast<float>();
    ASSERT_TRUE(g->add_constraint(p, f, p));
  }
  for (int f = 260; f < 300; f += 3) {
    const Eigen::Vector3f p = (pose_at(f) * Eigen::Vector3d(0, 0, 1)).cast<float>();
    ASSERT_TRUE(g->add_constraint(p, f, p + shift));
  }
  DeformationResult r;
  ASSERT_TRUE(g->optimise(&r).ok());
  auto h = PoseHistory::create(400);
  ASSERT_TRUE(h.ok());
  for (int f = 0; f < 300; ++f) h->push(f, stamp(f), pose_at(f));
  ASSERT_TRUE(test::allocation_counting_enabled());
  {
    test::AllocationCounter count;
    h->deform(*g);
    EXPECT_EQ(count.thread_allocations(), 0u);
  }
  EXPECT_EQ(h->deformations(), 1);
  for (int f = 0; f < 300; f += 7) {
    SE3 T;
    ASSERT_TRUE(h->at_frame(f, &T));
    const SE3 expected = g->apply_pose(pose_at(f), f);
    EXPECT_LT((T.translation() - expected.translation()).norm(), 1e-12) << f;
    EXPECT_LT(T.rotation().angularDistance(expected.rotation()), 1e-12) << f;
  }
  SE3 start, end;
  ASSERT_TRUE(h->at_frame(10, &start) && h->at_frame(290, &end));
  EXPECT_LT((start.translation() - pose_at(10).translation()).norm(), 0.005);            // pinned
  EXPECT_GT((end.translation() - pose_at(290).translation()).y(), 0.05);  // moved with the end (its 10 cm)
}

}  // namespace
}  // namespace ef::slam
