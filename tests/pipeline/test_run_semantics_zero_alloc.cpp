// The semantic half of a run (segment, fuse through the index map, render) must not touch the heap
// per frame once created, like the SLAM it follows: `edgefusion run`'s per-frame path after
// SurfelSlam::process (src/pipeline/run_semantics.h), with the CNN on every frame: results fused at
// their own frame and results fused one frame late (an index map rendered at their frame's pose).
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "support/alloc_counter.h"
#include "core/stage_stats.h"
#include "pipeline/cnn_worker.h"
#include "pipeline/run_config.h"
#include "pipeline/run_semantics.h"
#include "io/frame_source.h"
#include "semantic/label_render.h"
#include "semantic/semantic_test_util.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef {
namespace {

TEST(RunSemanticsZeroAlloc, SegmentFuseAndRenderAllocateNothingPerFrame) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  const auto dir = test::scratch_dir("run-semantics-zero-alloc");
  const auto model = test::write_tiny_seg_model(dir);

  auto source = open_source("synthetic:?frames=10&size=160x120");
  ASSERT_TRUE(source.ok());
  const Intrinsics K = (*source)->info().intrinsics;
  pipeline::RunConfig config;
  config.run.resolution.width = K.width;
  config.run.resolution.height = K.height;
  config.mapping.pool.capacity = 100'000;
  config.labels.model = model.string();
  config.label_fusion.update_every_n_frames = 1;  // the CNN and the update on every frame
  StageStats stats;
  auto sem = pipeline::RunSemantics::create(pipeline::semantics_options(config), K, stats);
  ASSERT_TRUE(sem.ok()) << to_string(sem.error());
  slam::SurfelSlamOptions so;
  so.pool.capacity = config.mapping.pool.capacity;
  auto slam = slam::SurfelSlam::create(K, so);
  ASSERT_TRUE(slam.ok());

  Frame frame;
  frame.allocate(K.width, K.height, true);
  slam::SlamFrameResult result;
  Image<uint8_t> rendered(K.width, K.height);
  auto cnn = pipeline::CnnWorker::create(**sem, K.width, K.height, /*threaded=*/false);
  ASSERT_TRUE(cnn.ok());
  uint64_t allocations = 0;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(*(*source)->next(frame));
    test::AllocationCounter count;  // the source's rendering is not part of the path
    ASSERT_TRUE(slam->process(frame, &result).ok());
    // Even frames: the CNN's result is there when the frame is mapped. Odd frames: it is queued
    // after, and fused while the next frame is mapped, at this one's pose.
    const bool on_time = i % 2 == 0;
    if (on_time) {
      ASSERT_TRUE((*cnn)->offer(frame, i, /*fuse=*/true, /*wait=*/true));
    }
    ASSERT_TRUE((*sem)->on_frame(i, frame, on_time, result, *slam, **cnn).ok());
    if (!on_time) {
      ASSERT_TRUE((*cnn)->offer(frame, i, /*fuse=*/true, /*wait=*/true));
    }
    const auto& fused = (*sem)->last_fused();
    EXPECT_EQ(fused.frame, on_time ? i : i - 1) << "frame " << i;
    // The rendering --labels-out writes (the PNG encoder itself is outside the per-frame path).
    ASSERT_TRUE(semantic::render_labels(slam->predictor(), slam->pool(), {}, rendered.view(), frame.depth.view()).ok());
    if (i >= 3) allocations += count.thread_allocations();  // frames 0-2: warm-up (dispatch choices)
  }
  EXPECT_EQ(stats.counter(stats.counter_id("cnn_results_late")), 4u);  // frames 1, 3, 5, 7 (9's is still queued)
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(slam->pool().size(), 1000);
}

}  // namespace
}  // namespace ef
