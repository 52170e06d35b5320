// Map checkpoints (pipeline/checkpoint.h): a SLAM restored from one is the SLAM that was saved, bit
// for bit, and the next frames give the same results as in the SLAM that went on uninterrupted.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <optional>

#include "core/stage_stats.h"
#include "pipeline/checkpoint.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"
#include "support/alloc_counter.h"
#include "test_support.h"

namespace ef::pipeline {
namespace {

namespace fs = std::filesystem;

bool same_pose(const SE3& a, const SE3& b) {
  return a.rotation().coeffs() == b.rotation().coeffs() && a.translation() == b.translation();
}

bool same_pool(const slam::SurfelPool& a, const slam::SurfelPool& b) {
  const auto n = static_cast<std::size_t>(a.size());
  if (a.size() != b.size()) return false;
  const auto eq = [n](const void* x, const void* y, std::size_t bytes) { return std::memcmp(x, y, n * bytes) == 0; };
  return eq(a.x(), b.x(), 4) && eq(a.y(), b.y(), 4) && eq(a.z(), b.z(), 4) && eq(a.nx(), b.nx(), 4) &&
         eq(a.ny(), b.ny(), 4) && eq(a.nz(), b.nz(), 4) && eq(a.radius(), b.radius(), 4) &&
         eq(a.confidence(), b.confidence(), 4) && eq(a.color(), b.color(), 4) && eq(a.init_time(), b.init_time(), 4) &&
         eq(a.last_seen(), b.last_seen(), 4) && eq(a.labels(), b.labels(), slam::SurfelPool::kLabelBytesPerSurfel) &&
         a.counters().created == b.counters().created && a.counters().removed == b.counters().removed;
}

TEST(Checkpoint, ARestoredSlamIsTheSavedOneAndGoesOnTheSame) {
  const auto dir = test::scratch_dir("checkpoint-slam");
  auto source = open_source("synthetic:bedroom?frames=40&size=160x120");
  ASSERT_TRUE(source.ok());
  const Intrinsics k = (*source)->info().intrinsics;
  slam::SurfelSlamOptions options;
  options.pool.capacity = 200000;
  options.pose_history = 16;  // wraps during the checkpoints below
  auto a = slam::SurfelSlam::create(k, options);
  ASSERT_TRUE(a.ok());
  Frame f;
  slam::SlamFrameResult ra, rb;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(*(*source)->next(f));
    ASSERT_TRUE(a->process(f, &ra).ok());
  }
  // Labels the saved map carries: a pattern in the label column.
  for (int64_t i = 0; i < a->pool().size(); ++i) a->pool_for_labels().labels()[i * 16 + 3] = uint8_t(i * 7);
  StageStats stats;
  const int counter = stats.add_counter("frames");
  std::string names;
  auto b = slam::SurfelSlam::create(k, options);
  ASSERT_TRUE(b.ok());
  StageStats restored_stats;
  const int restored_counter = restored_stats.add_counter("frames");
  std::optional<FoundCheckpoint> found;
  // A checkpoint after each of 15 frames, each restored into the second SLAM: every pose's bits
  // (a quaternion normalised once more moves its last bits on some frames, not on others).
  for (int i = 10; i < 25; ++i) {
    ASSERT_TRUE(*(*source)->next(f));
    ASSERT_TRUE(a->process(f, &ra).ok());
    stats.set_counter(counter, uint64_t(i + 1));
    CheckpointMeta meta;
    meta.frames = a->frames();
    meta.width = k.width;
    meta.height = k.height;
    meta.capacity = options.pool.capacity;
    meta.trajectory_bytes = 1000 + i;
    meta.labels = true;
    ASSERT_TRUE(write_checkpoint(dir.string(), meta, *a, stats, names).ok());
    auto got = find_checkpoint(dir.string());
    ASSERT_TRUE(got.ok()) << to_string(got.error());
    found = std::move(*got);
    EXPECT_EQ(found->meta.frames, i + 1);
    EXPECT_EQ(found->meta.trajectory_bytes, 1000 + i);
    EXPECT_TRUE(found->meta.labels);
    EXPECT_EQ(found->warning, "");
    ASSERT_TRUE(restore_checkpoint(*found, *b, restored_stats).ok());
    EXPECT_EQ(restored_stats.counter(restored_counter), uint64_t(i + 1));
    const slam::SurfelSlam::State sa = a->state(), sb = b->state();
    ASSERT_TRUE(same_pose(sa.T_world_last, sb.T_world_last)) << "frame " << i;  // no renormalisation
    ASSERT_TRUE(same_pose(sa.last_motion, sb.last_motion)) << "frame " << i;
    EXPECT_EQ(sa.frames, sb.frames);
    EXPECT_EQ(sa.fused_frames, sb.fused_frames);
    EXPECT_EQ(sa.lost_frames, sb.lost_frames);
    EXPECT_EQ(sa.sweep_cursor, sb.sweep_cursor);
    EXPECT_EQ(sa.predicted_frame, sb.predicted_frame);
    EXPECT_EQ(sa.predicted_min_confidence, sb.predicted_min_confidence);
    EXPECT_EQ(sa.lost_run, sb.lost_run);
    EXPECT_EQ(sa.relocalisations, sb.relocalisations);
    EXPECT_EQ(sa.inlier_reference, sb.inlier_reference);
    EXPECT_EQ(sa.inlier_samples, sb.inlier_samples);
    ASSERT_TRUE(same_pool(a->pool(), b->pool())) << "frame " << i;
    // The relocaliser's keyframes, code for code and pose for pose.
    const slam::KeyframeFerns &ka = a->keyframes(), &kb = b->keyframes();
    ASSERT_GT(ka.size(), 0);
    ASSERT_EQ(ka.size(), kb.size());
    for (int32_t kf = 0; kf < ka.size(); ++kf) {
      EXPECT_EQ(std::memcmp(ka.code(kf), kb.code(kf), static_cast<std::size_t>(ka.ferns())), 0) << kf;
      EXPECT_TRUE(same_pose(ka.pose(kf), kb.pose(kf))) << kf;
      EXPECT_EQ(ka.frame(kf), kb.frame(kf));
    }
    // The pose history loop closure corrects, pose for pose.
    const slam::PoseHistory &ha = a->pose_history(), &hb = b->pose_history();
    ASSERT_EQ(ha.size(), std::min<int64_t>(i + 1, 16));
    EXPECT_EQ(ha.size(), hb.size());
    EXPECT_EQ(ha.first_frame(), hb.first_frame());
    EXPECT_EQ(ha.overwritten(), hb.overwritten());
    EXPECT_EQ(ha.deformations(), hb.deformations());
    for (int64_t h = ha.first_frame(); h <= i; ++h) {
      SE3 pa, pb;
      ASSERT_TRUE(ha.at_frame(h, &pa) && hb.at_frame(h, &pb)) << h;
      EXPECT_TRUE(same_pose(pa, pb)) << h;
    }
  }

  // The next frames: the same poses and the same map, bit for bit.
  for (int i = 25; i < 40; ++i) {
    ASSERT_TRUE(*(*source)->next(f));
    ASSERT_TRUE(a->process(f, &ra).ok());
    ASSERT_TRUE(b->process(f, &rb).ok());
    ASSERT_TRUE(same_pose(ra.T_world_cam, rb.T_world_cam)) << "frame " << i;
  }
  EXPECT_TRUE(same_pool(a->pool(), b->pool()));

  // A pool too small for the checkpoint is refused, naming the key to raise.
  options.pool.capacity = 1000;
  auto small = slam::SurfelSlam::create(k, options);
  ASSERT_TRUE(small.ok());
  auto s = restore_checkpoint(*found, *small, restored_stats);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("mapping.surfel_capacity"), std::string::npos) << s.error().message;
}

// fuzz_snapshot's finding (issue 34): a 4 kB checkpoint, every CRC right, whose POOL header claims
// 50,000,000 surfels over a section that holds 48. load_checkpoint_pool (export, view) sized a pool
// by the claim before reading the section: 3 GB allocated and zeroed for a few kB of file. Now the
// claim is checked against the section's length first: an error naming POOL, and no large allocation.
TEST(Checkpoint, ASurfelCountTheSectionDoesNotHoldIsRefusedBeforeAnyAllocation) {
  const auto dir = test::scratch_dir("checkpoint-pool-count");
  fs::copy_file(fs::path(EF_SOURCE_DIR) / "tests/data/fuzz/checkpoint_pool_count_50M.efs", dir / kCheckpointFile);
  auto found = find_checkpoint(dir.string());
  ASSERT_TRUE(found.ok()) << to_string(found.error());  // the container and META are whole
  ASSERT_TRUE(test::allocation_counting_enabled());
  test::AllocationCounter count;
  auto pool = load_checkpoint_pool(*found);
  const uint64_t bytes = count.thread_bytes();
  ASSERT_FALSE(pool.ok());
  EXPECT_EQ(pool.error().code, ErrorCode::kCorruptData);
  EXPECT_NE(pool.error().message.find("section POOL has 2944 bytes; 50000000 surfels take 3000000064"),
            std::string::npos)
      << pool.error().message;
  EXPECT_LT(bytes, uint64_t{1} << 20);  // messages only: the 3 GB pool is never asked for

  // restore_checkpoint (run --resume) reads the same header: the same error, before the pool is read.
  slam::SurfelSlamOptions options;
  options.pool.capacity = 100;
  auto slam = slam::SurfelSlam::create(Intrinsics{26.25f, 26.25f, 15.5f, 15.5f, 32, 32}, options);
  ASSERT_TRUE(slam.ok());
  StageStats stats;
  auto s = restore_checkpoint(*found, *slam, stats);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("section POOL has 2944 bytes"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace ef::pipeline
