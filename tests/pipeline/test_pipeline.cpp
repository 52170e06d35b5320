// The pipeline of `edgefusion run` (src/pipeline/run_pipeline.h), driven in-process:
//   - one, two and three threads give byte-identical trajectory and map (front and CNN read
//     nothing mapping writes);
//   - 3000 steady-state frames through every step on three threads allocate nothing;
//   - a stop request drains: every frame the front stage prepared is mapped, outputs complete;
//   - a live camera that vanishes mid-run leaves complete outputs and exit status "camera lost".
// In test_core so that it runs under ThreadSanitizer in CI.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/alloc_counter.h"
#include "core/stage_stats.h"
#include "io/mcap_reader.h"
#include "pipeline/checkpoint.h"
#include "pipeline/run_pipeline.h"
#include "pipeline/run_folder.h"
#include "io/frame_source.h"
#include "semantic/semantic_test_util.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef {
namespace {

// A source that replays a few frames of the synthetic office back and forth (0..n-1, n-2..1, ...),
// so that tracking stays continuous over thousands of frames at no rendering cost. Optionally
// live (paced, as a camera) and ending with an error after `limit` frames (a camera unplugged).
// It counts the heap allocations of its own next() (none are expected; copy_frame reuses buffers).
class LoopSource : public FrameSource {
 public:
  LoopSource(int distinct_frames, int64_t limit, bool live = false, std::optional<Error> final_error = std::nullopt,
             std::chrono::microseconds period = std::chrono::microseconds(0))
      : limit_(limit), final_error_(std::move(final_error)), period_(period) {
    auto synth = open_source("synthetic:?frames=" + std::to_string(distinct_frames) + "&size=160x120");
    EXPECT_TRUE(synth.ok());
    info_ = (*synth)->info();
    info_.uri = "loop:";
    info_.frame_count = live ? -1 : limit;
    info_.live = live;
    frames_.resize(static_cast<std::size_t>(distinct_frames));
    for (Frame& f : frames_) {
      f.allocate(info_.intrinsics.width, info_.intrinsics.height, info_.has_labels);
      EXPECT_TRUE(*(*synth)->next(f));
    }
  }
  const SourceInfo& info() const override { return info_; }
  Result<bool> next(Frame& out) override {
    const test::AllocationCounter count;
    if (next_ == limit_) {
      if (final_error_) return *final_error_;
      return false;
    }
    if (period_.count() > 0) {
      if (next_ == 0) start_ = std::chrono::steady_clock::now();
      std::this_thread::sleep_until(start_ + period_ * next_);
    }
    const int n = static_cast<int>(frames_.size());
    const int64_t phase = next_ % (2 * n - 2);
    copy_frame(frames_[static_cast<std::size_t>(phase < n ? phase : 2 * n - 2 - phase)], out);
    out.index = next_;
    out.timestamp = 1.0 + static_cast<double>(next_) / 30.0;
    ++next_;
    own_allocations_.fetch_add(count.thread_allocations(), std::memory_order_relaxed);
    return true;
  }
  uint64_t own_allocations() const { return own_allocations_.load(); }
  int64_t produced() const { return next_; }

 private:
  SourceInfo info_;
  std::vector<Frame> frames_;
  int64_t limit_;
  std::optional<Error> final_error_;
  std::chrono::microseconds period_;
  std::chrono::steady_clock::time_point start_;
  int64_t next_ = 0;
  std::atomic<uint64_t> own_allocations_{0};
};

pipeline::RunConfig small_run(const std::filesystem::path& dir, const std::string& model, int threads) {
  pipeline::RunConfig c;
  c.run.resolution.width = 160;
  c.run.resolution.height = 120;
  c.mapping.pool.capacity = 60'000;
  c.labels.model = model;
  c.label_fusion.update_every_n_frames = 5;
  c.pipeline.threads = threads;
  c.run.progress = false;
  c.run.out = dir.string();
  return c;
}

std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string tiny_model(const std::filesystem::path& dir) { return test::write_tiny_seg_model(dir).string(); }

// Stops the run after `stop_after` mapped frames (never when < 0).
class StopAfter : public pipeline::RunObserver {
 public:
  explicit StopAfter(int64_t stop_after) : stop_after_(stop_after) {}
  bool stop_requested(const pipeline::RunPipeline& p) override {
    return stop_after_ >= 0 && p.mapping().frames() >= stop_after_;
  }

 private:
  int64_t stop_after_;
};

// A deterministic run (pipeline.deterministic: the CNN takes exactly the due frames, mapping waits
// for each result) gives the outputs of one thread on two and three; without it the geometry is
// still the same, whenever the CNN finishes.
TEST(Pipeline, OneTwoAndThreeThreadsGiveIdenticalOutputs) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  const auto dir = test::scratch_dir("pipeline-threads");
  const std::string model = tiny_model(dir);
  // The sanitizers' short form: 20 frames (4 CNN passes) for each of the six runs; 40 took 54 s
  // under TSan (stop 48).
  constexpr int kFrames = test::frames_native_or_emulated(40, 20);
  constexpr uint64_t kCnnFrames = kFrames / 5;  // frames 0, 5, 10, ... (update_every_n_frames 5)
  for (const bool deterministic : {true, false}) {
    std::string trajectory[3], map[3];
    for (int threads = 1; threads <= 3; ++threads) {
      LoopSource source(12, kFrames);
      StageStats stats;
      const auto out = dir / ("t" + std::to_string(threads) + (deterministic ? "d" : "a"));
      pipeline::RunConfig config = small_run(out, model, threads);
      config.pipeline.deterministic = deterministic;
      auto p = pipeline::RunPipeline::create(config, source, stats);
      ASSERT_TRUE(p.ok()) << to_string(p.error());
      pipeline::RunObserver none;
      const pipeline::RunOutcome outcome = (*p)->run(none);
      EXPECT_FALSE(outcome.error.has_value()) << to_string(*outcome.error);
      EXPECT_EQ(outcome.frames, kFrames);
      const pipeline::OutputFiles files = (*p)->write_outputs(outcome);
      EXPECT_TRUE(files.errors.empty());
      const uint64_t cnn_frames = stats.counter(stats.counter_id("cnn_frames"));
      const uint64_t skipped = stats.counter(stats.counter_id("cnn_frames_skipped"));
      if (deterministic || threads == 1) {
        EXPECT_EQ(cnn_frames, kCnnFrames);
        EXPECT_EQ(skipped, 0u);
      } else {
        EXPECT_EQ(cnn_frames + skipped, kCnnFrames) << "every request is served or counted as skipped";
      }
      trajectory[threads - 1] = read_file(files.trajectory);
      map[threads - 1] = read_file(files.map);
    }
    EXPECT_GT(trajectory[0].size(), std::size_t(kFrames) * 20);
    EXPECT_GT(map[0].size(), 10'000u);
    for (int t = 1; t < 3; ++t) {
      EXPECT_EQ(trajectory[0], trajectory[t]) << t + 1 << " threads";
      if (deterministic) {
        EXPECT_TRUE(map[0] == map[t]) << "map.ply differs between one and " << t + 1 << " threads";
      }
    }
  }
}

// Issue 28: a CNN far slower than mapping (here 10x a frame's mapping time) must not slow the
// mapping: it takes a frame when it is free, its result is fused at that frame's own pose when it
// comes, and the requests it could not take are counted.
TEST(Pipeline, SlowCnnNeitherHoldsMappingBackNorFusesAtTheWrongPose) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  const auto dir = test::scratch_dir("pipeline-slow-cnn");
  const std::string model = tiny_model(dir);
  // 60 frames in the sanitizers' short form (30 requests, a few served): 120 took 36 s under TSan.
  constexpr int kFrames = test::frames_native_or_emulated(120, 60);
  // Mapping rate without labels, the reference.
  double plain_seconds = 0;
  {
    LoopSource source(12, kFrames);
    StageStats stats;
    pipeline::RunConfig config = small_run(dir / "plain", model, 3);
    config.labels.enabled = false;
    auto p = pipeline::RunPipeline::create(config, source, stats);
    ASSERT_TRUE(p.ok()) << to_string(p.error());
    pipeline::RunObserver none;
    const pipeline::RunOutcome outcome = (*p)->run(none);
    ASSERT_FALSE(outcome.error.has_value());
    plain_seconds = outcome.seconds;
  }
  const double frame_ms = 1000.0 * plain_seconds / kFrames;

  LoopSource source(12, kFrames);
  StageStats stats;
  pipeline::RunConfig config = small_run(dir / "slow", model, 3);
  config.label_fusion.update_every_n_frames = 2;
  config.pipeline.test_cnn_delay_ms = 10 * frame_ms;
  auto p = pipeline::RunPipeline::create(config, source, stats);
  ASSERT_TRUE(p.ok()) << to_string(p.error());
  // After each mapped frame: the pose of every frame, and each newly fused result's frame and pose.
  class Watch : public pipeline::RunObserver {
   public:
    void frame_mapped(const pipeline::RunPipeline& p) override {
      poses[std::size_t(p.mapping().frames() - 1)] = p.mapping().last_result().T_world_cam;
      const auto& f = p.semantics()->last_fused();
      if (f.frame >= 0 && f.frame != last_frame) {
        last_frame = f.frame;
        fused.push_back(f);
      }
    }
    std::vector<SE3> poses = std::vector<SE3>(kFrames);
    std::vector<pipeline::RunSemantics::FusedResult> fused;
    int64_t last_frame = -1;
  } watch;
  watch.fused.reserve(kFrames);
  const pipeline::RunOutcome outcome = (*p)->run(watch);
  ASSERT_FALSE(outcome.error.has_value()) << to_string(*outcome.error);
  ASSERT_EQ(outcome.frames, kFrames);
  // Mapping did not wait for the CNN: serving every request (one every 2nd frame) would have taken
  // the CNN kFrames / 2 x its delay, 5 times the plain run; the run took far less.
  const double serve_all_seconds = (kFrames / 2) * config.pipeline.test_cnn_delay_ms / 1000.0;
  EXPECT_LT(outcome.seconds, 0.5 * serve_all_seconds) << "plain run " << plain_seconds << " s";
  const uint64_t cnn_frames = stats.counter(stats.counter_id("cnn_frames"));
  const uint64_t skipped = stats.counter(stats.counter_id("cnn_frames_skipped"));
  const uint64_t late = stats.counter(stats.counter_id("cnn_results_late"));
  EXPECT_GT(skipped, 0u);
  EXPECT_GT(late, 0u);
  EXPECT_GE(cnn_frames, 2u);
  EXPECT_EQ(cnn_frames + skipped, uint64_t(kFrames / 2)) << "every request is served or counted as skipped";
  ASSERT_FALSE(watch.fused.empty());
  for (const auto& f : watch.fused) {
    EXPECT_LE(f.frame, f.fused_at);
    // The pose the result met is its own frame's, not the frame being mapped when it came.
    EXPECT_TRUE(f.T_world_cam.matrix().isApprox(watch.poses[std::size_t(f.frame)].matrix(), 1e-12))
        << "result of frame " << f.frame << " fused at frame " << f.fused_at;
  }
}

// Issue 7: "over 3000 steady-state frames: zero heap allocations". Every step, three threads, the
// CNN every 5th frame; the global counter sees the front and CNN threads too.
TEST(Pipeline, ThreeThousandFramesOnThreeThreadsAllocateNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  // qemu and the sanitizers (5-60x slower): 100 frames, 20 CNN passes and label fusions, every step
  // on its thread past its warm-up; 300 took a minute under qemu and under TSan each (stop 48).
  constexpr int64_t kFrames = test::kShortForm ? 100 : 3000;
  constexpr int64_t kWarmUp = 10;  // first frames: dispatch choices, the map's first growth
  // The source goes on past the counted frames: when the front and CNN threads end, OpenCV's
  // thread-local storage allocates in its destructor (once per thread, not per frame).
  constexpr int64_t kTail = 10;
  const auto dir = test::scratch_dir("pipeline-zero-alloc");
  LoopSource source(16, kWarmUp + kFrames + kTail);
  StageStats stats;
  pipeline::RunConfig config = small_run(dir, tiny_model(dir), 3);
  // Checkpoints are not per-frame work: one every 30 s opens its file and builds its paths (a few
  // dozen small blocks; under the sanitizers this test runs past 30 s). stats.json's rewrites are
  // counted, every 0.5 s here: they allocate nothing.
  config.output.checkpoint_seconds = 0;
  config.output.stats_seconds = 0.5;
  auto p = pipeline::RunPipeline::create(config, source, stats);
  ASSERT_TRUE(p.ok()) << to_string(p.error());

  // Counts from the end of the warm-up to the last mapped frame, on every thread.
  class Counting : public pipeline::RunObserver {
   public:
    void frame_mapped(const pipeline::RunPipeline& p) override {
      if (p.mapping().frames() == kWarmUp) count.restart();
      if (p.mapping().frames() == kWarmUp + kFrames) allocations = count.global_allocations();
    }
    test::AllocationCounter count;
    uint64_t allocations = ~0ull;
  } counting;
  const uint64_t source_before = source.own_allocations();
  const pipeline::RunOutcome outcome = (*p)->run(counting);
  ASSERT_FALSE(outcome.error.has_value()) << to_string(*outcome.error);
  ASSERT_EQ(outcome.frames, kWarmUp + kFrames + kTail);
  EXPECT_EQ(source.own_allocations() - source_before, 0u);
  EXPECT_EQ(counting.allocations, 0u) << "heap allocations over " << kFrames << " steady-state frames";
  EXPECT_EQ((*p)->slam().lost_frames(), 0);
  // A map was made: at 160x120, fusing every other pixel of every other row (the default), the
  // first frame alone gives up to 4,800 surfels.
  EXPECT_GT((*p)->slam().pool().size(), 3000);
}

TEST(Pipeline, StopRequestDrainsEveryPreparedFrameAndWritesOutputs) {
  const auto dir = test::scratch_dir("pipeline-stop");
  LoopSource source(12, 1000);
  StageStats stats;
  auto p = pipeline::RunPipeline::create(small_run(dir, tiny_model(dir), 2), source, stats);
  ASSERT_TRUE(p.ok()) << to_string(p.error());
  StopAfter stop(8);
  const pipeline::RunOutcome outcome = (*p)->run(stop);
  EXPECT_TRUE(outcome.stopped);
  EXPECT_FALSE(outcome.error.has_value());
  // Every frame the source gave was prepared and mapped: none left in the ring.
  EXPECT_GE(outcome.frames, 8);
  EXPECT_LT(outcome.frames, 1000);
  EXPECT_EQ(outcome.frames, source.produced());
  const pipeline::OutputFiles files = (*p)->write_outputs(outcome);
  EXPECT_TRUE(files.wrote_trajectory && files.wrote_map && files.wrote_stats);
  std::ifstream t(files.trajectory);
  int64_t poses = 0;
  for (std::string line; std::getline(t, line);)
    if (!line.empty() && line[0] != '#') ++poses;
  EXPECT_EQ(poses, outcome.frames);
}

TEST(Pipeline, VanishingCameraLeavesCompleteOutputs) {
  const auto dir = test::scratch_dir("pipeline-camera-lost");
  for (int threads : {1, 3}) {
    const auto out = dir / ("t" + std::to_string(threads));
    // A live camera at 200 Hz that is unplugged after 25 frames (kNotFound: is_camera_lost).
    LoopSource camera(12, 25, /*live=*/true, error(ErrorCode::kNotFound, "loop: camera lost (unplugged)"),
                      std::chrono::milliseconds(5));
    StageStats stats;
    pipeline::RunConfig c = small_run(out, tiny_model(dir), threads);
    c.pipeline.capture_slots = 64;  // room for every frame: the count below is exact
    auto p = pipeline::RunPipeline::create(c, camera, stats);
    ASSERT_TRUE(p.ok()) << to_string(p.error());
    pipeline::RunObserver none;
    const pipeline::RunOutcome outcome = (*p)->run(none);
    EXPECT_TRUE(outcome.camera_lost) << threads;
    EXPECT_FALSE(outcome.error.has_value()) << to_string(*outcome.error);
    EXPECT_EQ(outcome.frames, 25) << "every frame captured before the camera vanished is mapped";
    EXPECT_EQ(stats.counter(stats.counter_id("camera_lost")), 1u);
    const pipeline::OutputFiles files = (*p)->write_outputs(outcome);
    EXPECT_TRUE(files.errors.empty());
    const std::string ply = read_file(files.map);
    EXPECT_EQ(ply.rfind("ply\n", 0), 0u);
    EXPECT_NE(ply.find("element vertex " + std::to_string((*p)->slam().pool().size())), std::string::npos);
    EXPECT_GT((*p)->slam().pool().size(), 1000);
    EXPECT_NE(read_file(files.stats).find("\"camera_lost\":1"), std::string::npos);
    // The end it states: what a restarted service continues (output.resume_interrupted).
    EXPECT_EQ(pipeline::run_state(out.string()), "camera lost");
  }
}

// --realtime on a recording the machine cannot keep up with (issue 33): a source that takes 100 ms
// per frame recorded at 30 Hz falls further behind with every frame; the late frames are counted
// (and still mapped: a replay drops nothing), with the most behind.
TEST(Pipeline, RealtimeCountsTheFramesTheMachineReleasesLate) {
  const auto dir = test::scratch_dir("pipeline-realtime-late");
  LoopSource slow(6, 15, /*live=*/false, std::nullopt, std::chrono::milliseconds(100));
  StageStats stats;
  pipeline::RunConfig c = small_run(dir, tiny_model(dir), 1);
  c.labels.enabled = false;
  c.run.realtime = true;
  auto p = pipeline::RunPipeline::create(c, slow, stats);
  ASSERT_TRUE(p.ok()) << to_string(p.error());
  pipeline::RunObserver none;
  const pipeline::RunOutcome outcome = (*p)->run(none);
  EXPECT_EQ(outcome.frames, 15) << "late frames are mapped, not dropped";
  // Frame k is due k/30 s after the first and comes k/10 s after it: more than 100 ms late from
  // the third frame on.
  EXPECT_GE((*p)->realtime_late_frames(), 11u);
  EXPECT_LE((*p)->realtime_late_frames(), 14u);
  EXPECT_GE((*p)->realtime_max_late_ms(), 800);
  const pipeline::OutputFiles files = (*p)->write_outputs(outcome);
  EXPECT_NE(read_file(files.stats).find("\"realtime_frames_late\":" + std::to_string((*p)->realtime_late_frames())),
            std::string::npos);
}

// A preview.png that a checkpoint cannot write (a folder of that name in the way) does not stop the
// mapping: every frame is mapped and every checkpoint written; the failures are counted and the
// first kept, naming the file, for the run's one warning. The final picture's failure is then the
// outputs' error, the other outputs complete.
TEST(Pipeline, APreviewACheckpointCannotWriteDoesNotStopTheMapping) {
  const auto dir = test::scratch_dir("pipeline-preview-blocked");
  // 20 frames in the short form (qemu, sanitizers), whose frames take longer than the 0.1 s between
  // checkpoints by themselves: 50 took 30 s under TSan and 22 s under qemu.
  constexpr int64_t kFrames = test::frames_native_or_emulated(50, 20);
  LoopSource paced(12, kFrames, /*live=*/false, std::nullopt, std::chrono::milliseconds(10));  // 0.5 s
  StageStats stats;
  pipeline::RunConfig c = small_run(dir, tiny_model(dir), 2);
  c.output.checkpoint_seconds = 0.1;
  auto p = pipeline::RunPipeline::create(c, paced, stats);
  ASSERT_TRUE(p.ok()) << to_string(p.error());
  std::filesystem::create_directories(dir / "preview.png" / "in-the-way");
  pipeline::RunObserver none;
  const pipeline::RunOutcome outcome = (*p)->run(none);
  ASSERT_FALSE(outcome.error.has_value()) << to_string(*outcome.error);
  EXPECT_EQ(outcome.frames, kFrames);
  const uint64_t failed = stats.counter(stats.counter_id("checkpoint_previews_failed"));
  EXPECT_GE(failed, 1u);
  EXPECT_TRUE(std::filesystem::exists(dir / pipeline::kCheckpointFile));
  ASSERT_TRUE((*p)->checkpoint_preview_error().has_value());
  EXPECT_NE((*p)->checkpoint_preview_error()->message.find("preview.png"), std::string::npos)
      << (*p)->checkpoint_preview_error()->message;
  const pipeline::OutputFiles files = (*p)->write_outputs(outcome);
  EXPECT_TRUE(files.wrote_trajectory && files.wrote_map && files.wrote_stats);
  EXPECT_FALSE(files.wrote_preview);
  ASSERT_FALSE(files.errors.empty());
  EXPECT_NE(files.errors.front().message.find("preview.png"), std::string::npos) << files.errors.front().message;
  EXPECT_NE(read_file(files.stats).find("\"checkpoint_previews_failed\":" + std::to_string(failed)), std::string::npos);
}

TEST(Pipeline, BadCoreIsAnErrorNamingTheKey) {
  const auto dir = test::scratch_dir("pipeline-bad-core");
  LoopSource source(4, 4);
  StageStats stats;
  pipeline::RunConfig c = small_run(dir, tiny_model(dir), 2);
  c.labels.enabled = false;
  c.pipeline.mapping_cpu = 1023;
  auto p = pipeline::RunPipeline::create(c, source, stats);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("pipeline.mapping_cpu 1023"), std::string::npos) << p.error().message;
}

// Issue 29: the field log is written by three threads at once (the front's frames, the mapping
// thread's poses, lines and the CNN's class ids) on three threads: every frame, pose and CNN
// result is in it once, readable (and TSan sees the log's lock at work).
TEST(Pipeline, FieldLogHoldsEveryFrameAndPoseAndCnnResultWithThreeThreads) {
  const auto dir = test::scratch_dir("pipeline-field-log");
  LoopSource source(12, 60);
  StageStats stats;
  pipeline::RunConfig config = small_run(dir / "run", tiny_model(dir), 3);
  config.log.file = "log.mcap";
  config.log.chunk_seconds = 0.2;
  auto p = pipeline::RunPipeline::create(config, source, stats);
  ASSERT_TRUE(p.ok()) << to_string(p.error());
  pipeline::RunObserver none;
  const pipeline::RunOutcome outcome = (*p)->run(none);
  ASSERT_FALSE(outcome.error.has_value()) << to_string(*outcome.error);
  const pipeline::OutputFiles files = (*p)->write_outputs(outcome);
  EXPECT_TRUE(files.errors.empty());
  ASSERT_TRUE(files.wrote_log);
  EXPECT_EQ(files.log_frames, 60u);
  McapReader log;
  ASSERT_TRUE(log.open(files.log).ok());
  EXPECT_TRUE(log.complete()) << log.warning();
  const auto count = [&](const char* topic) {
    const McapChannel* c = log.channel(topic);
    return c == nullptr ? uint64_t(0) : c->messages;
  };
  EXPECT_EQ(count("/camera/depth"), 60u);
  EXPECT_EQ(count("/edgefusion/pose"), 60u);
  EXPECT_EQ(count("/tf"), 60u);
  EXPECT_EQ(count("/edgefusion/labels"), stats.counter(stats.counter_id("cnn_frames")));
  EXPECT_GE(count("/edgefusion/labels"), 1u);
  std::string buf;
  for (const McapMessageRef& m : log.messages()) ASSERT_TRUE(log.read(m, buf).ok());
  EXPECT_GE(stats.summary(stats.stage_id("log")).count, 60u);
}

}  // namespace
}  // namespace ef
