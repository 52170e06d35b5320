// The whole SLAM core (preprocess, frame-to-model tracking, fusion, prediction) on synthetic
// sequences with exact poses, a frame of another scene, a tiny pool, a pan out and back (no duplicate
// surfels where known surface re-enters the view), and zero allocations per frame.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "support/alloc_counter.h"
#include "core/frame.h"
#include "eval/trajectory_eval.h"
#include "io/frame_resample.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"
#include "synth/renderer.h"
#include "synth/test_synth_support.h"
#include "test_support.h"

namespace ef::slam {
namespace {

// Runs `frames` frames of `uri` through a SurfelSlam; returns estimated and reference trajectories.
struct RunOutput {
  std::vector<TimedPose> estimate, reference;
  int64_t lost = 0;
  int64_t surfels = 0;
  int64_t gauss_newton_steps = 0;  // TrackResult::iterations summed over the frames
  int64_t reorders = 0;            // frames whose fusion reordered the pool
  uint64_t bounds_refreshes = 0;   // SurfelPool::bounds_refreshes() at the end
};

RunOutput run_sequence(const std::string& uri, int max_frames, const SurfelSlamOptions& options, bool verbose = false) {
  RunOutput out;
  auto src = open_source(uri);
  EXPECT_TRUE(src.ok()) << to_string(src.error());
  if (!src.ok()) return out;
  const SourceInfo& info = (*src)->info();
  // At the working resolution, as `edgefusion run` does.
  Frame input, frame;
  input.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  frame.allocate(320, 240, info.has_labels);
  auto slam = SurfelSlam::create(info.intrinsics.scaled_to(320, 240), options);
  EXPECT_TRUE(slam.ok()) << to_string(slam.error());
  if (!slam.ok()) return out;
  SlamFrameResult r;
  SE3 first_reference;
  while (static_cast<int>(out.estimate.size()) < max_frames) {
    auto got = (*src)->next(input);
    EXPECT_TRUE(got.ok());
    if (!got.ok() || !*got) break;
    resample_frame(input, frame);
    EXPECT_TRUE(slam->process(frame, &r).ok());
    if (out.reference.empty()) first_reference = frame.T_wc;
    if (verbose) {
      // Error of the pose relative to the first frame (the estimate starts at identity).
      const SE3 err = (first_reference.inverse() * frame.T_wc).inverse() * r.T_world_cam;
      std::printf("frame %3lld lost %d (%s) icp_rms %.4f inl %lld/%lld rgb %.1f cond %.0f it %d | surfels %lld new %lld "
                  "fused %lld | pose err %.4f m | ms pre %.1f trk %.1f fuse %.1f pred %.1f\n",
                  static_cast<long long>(frame.index), r.lost, track_lost_reason_name(r.track.reason),
                  r.track.icp_rms_m, static_cast<long long>(r.track.icp_inliers),
                  static_cast<long long>(r.track.valid_current), r.track.rgb_rms_grey, r.track.condition,
                  r.track.iterations, static_cast<long long>(slam->pool().size()),
                  static_cast<long long>(r.fusion.new_surfels), static_cast<long long>(r.fusion.fused_pixels),
                  err.translation().norm(), r.timings.preprocess_ms, r.timings.track_ms, r.timings.fuse_ms,
                  r.timings.predict_ms);
    }
    out.gauss_newton_steps += r.track.iterations;
    out.reorders += r.timings.reorder_ms > 0 ? 1 : 0;
    out.estimate.push_back({frame.timestamp, r.T_world_cam});
    out.reference.push_back({frame.timestamp, frame.T_wc});
  }
  out.lost = slam->lost_frames();
  out.surfels = slam->pool().size();
  out.bounds_refreshes = slam->pool().bounds_refreshes();
  return out;
}

// The run covered all `frames` frames and lost none (callers wrap it in ASSERT_NO_FATAL_FAILURE,
// so that a short run stops the test).
void expect_every_frame_tracked(const RunOutput& o, int frames) {
  ASSERT_EQ(o.estimate.size(), static_cast<std::size_t>(frames));
  EXPECT_EQ(o.lost, 0);
}

double ate_rmse(const RunOutput& o) {
  Trajectory gt{"reference", o.reference}, est{"estimate", o.estimate};
  auto ate = evaluate_ate(gt, est);
  EXPECT_TRUE(ate.ok());
  return ate.ok() ? ate->rmse_m : 1e9;
}

TEST(SurfelSlam, TracksASyntheticSequenceWithoutNoise) {
  // 60 frames of a 1000-frame loop: the motion of a hand-held camera at 30 Hz. Under qemu-user
  // (about 1 s a frame with the rendering) 30 frames: the same checks over half the motion.
  constexpr int kFrames = test::frames_native_or_emulated(60, 30);
  const RunOutput o = run_sequence("synthetic:office?noise=0&frames=1000&size=320x240", kFrames, {}, true);
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(o, kFrames));
  const double ate = ate_rmse(o);
  std::printf("[ slam ] every other pixel fused (the default): %d frames, ATE %.2f mm, %lld surfels\n", kFrames,
              ate * 1e3, static_cast<long long>(o.surfels));
  EXPECT_LT(ate, 0.005);  // metres
  // The default fuses every other pixel of every other row (FusionOptions::pixel_stride 2): a
  // quarter of the first frame's pixels, then what later views add; well below every pixel's map
  // (the next test: more than 30,000).
  EXPECT_GT(o.surfels, 5000);
  EXPECT_LT(o.surfels, 30000);
}

// Fusing every pixel (FusionOptions::pixel_stride 1, ElasticFusion's way) tracks the noise-free
// loop at the same accuracy, with a map several times denser than the default's.
TEST(SurfelSlam, FusingEveryPixelTracksASyntheticSequenceWithoutNoise) {
  constexpr int kFrames = test::frames_native_or_emulated(60, 12);
  SurfelSlamOptions every_pixel;
  every_pixel.fusion.pixel_stride = 1;
  const RunOutput o = run_sequence("synthetic:office?noise=0&frames=1000&size=320x240", kFrames, every_pixel, false);
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(o, kFrames));
  EXPECT_LT(ate_rmse(o), 0.005);  // metres
  EXPECT_GT(o.surfels, 30000);
}

// The Kinect-like colour camera (auto-exposure, vignetting) on an inspecting scan that faces a wall
// and the floor, where only colour measures the slide along their corner (issue 30's failing case,
// seed 7). Without the texture gate and the photometric gain the tracker followed the vignette and
// slid about 4 cm a frame along the wall; with them it holds.
TEST(SurfelSlam, AKinectLikeCameraBeforeABareWallDoesNotSlide) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  // Measured here (x86-64), with / without, 45 frames: 2.2 / 209 mm at the default (every other
  // pixel fused; 2.2 / 243 with one pixel's disc); fusing every pixel 9.3 / 223 mm, and 20 frames
  // 13.1 / 63 mm (the first three frames still slid 3.3, 1.6 and 0.8 cm: the map is then one or two
  // views, whose colours carry the same vignette as the frame).
  constexpr int kFrames = test::frames_native_or_emulated(45, 20);
  const std::string uri = "synthetic:random?seed=7&trajectory=inspect&camera=kinect&frames=300&size=320x240";
  const RunOutput on = run_sequence(uri, kFrames, {});
  SurfelSlamOptions before;
  before.tracker.rgb_gain = false;
  before.tracker.rgb_min_gradient_grey = 0;
  const RunOutput off = run_sequence(uri, kFrames, before);
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(on, kFrames));
  const double ate_on = ate_rmse(on), ate_off = ate_rmse(off);
  std::printf("seed-7 Kinect-camera scan, %d frames: ATE %.1f mm with the gate and the gain, %.1f mm without\n",
              kFrames, ate_on * 1e3, ate_off * 1e3);
  EXPECT_LT(ate_on, 0.02);  // metres
  EXPECT_GT(ate_off, 3 * ate_on);
}

// The same scan fusing every pixel (FusionOptions::pixel_stride 1). The default (every other pixel
// of every other row, the test above) gives each surfel its 2x2 cell's mean colour, so that the
// predicted intensity does not alias the wall's faint texture: with the one pixel's colour it slid
// (45 frames: 129 mm). Measured here (x86-64), 45 frames: 9.3 mm every pixel, 2.2 mm the default.
TEST(SurfelSlam, FusingEveryPixelHoldsAKinectLikeCameraBeforeABareWall) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  constexpr int kFrames = 45;
  SurfelSlamOptions every_pixel;
  every_pixel.fusion.pixel_stride = 1;
  const RunOutput o =
      run_sequence("synthetic:random?seed=7&trajectory=inspect&camera=kinect&frames=300&size=320x240", kFrames, every_pixel);
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(o, kFrames));
  const double ate = ate_rmse(o);
  std::printf("seed-7 Kinect-camera scan, every pixel fused, %d frames: ATE %.1f mm\n", kFrames, ate * 1e3);
  EXPECT_LT(ate, 0.02);  // metres
}

// The held-out inspecting scan seed 5005 turns toward a far wall beyond the depth range: for some 40
// frames from frame 505 the view holds the floor, the ceiling and one side wall, and only colour and
// a few edges hold the forward direction (the system's condition number reaches 2.9e4 fusing every
// other pixel). That direction is weak but seen: the frames must be tracked and fused, or the model
// never grows into the new view and tracking does not come back (the limit at 2e4: lost from frame
// 509 on, 133 frames of 1200, ATE 1.12 m; TrackerOptions::lost_max_condition).
TEST(SurfelSlam, AnInspectingScanWithItsFarWallOutOfRangeStaysTracked) {
  if (test::kShortForm) GTEST_SKIP() << "native, optimised builds only: 560 rendered and mapped frames";
  constexpr int kFrames = 560;
  const RunOutput o =
      run_sequence("synthetic:random?seed=5005&trajectory=inspect&frames=1200&size=320x240", kFrames, {});
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(o, kFrames));
  const double ate = ate_rmse(o);
  std::printf("seed-5005 inspecting scan, %d frames: ATE %.1f mm\n", kFrames, ate * 1e3);
  EXPECT_LT(ate, 0.03);  // metres
}

// The constant-velocity guess (the default) starts each frame from the last pose times the last
// motion: on a smoothly moving camera it is far closer to the answer than the last pose, so the
// tracker needs fewer Gauss-Newton steps to reach its stop thresholds, and tracks as well.
TEST(SurfelSlam, ConstantVelocityGuessStartsCloserToTheAnswer) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  constexpr int kFrames = test::frames_native_or_emulated(40, 20);
  const std::string uri = "synthetic:office?noise=1&frames=300&size=320x240";
  SurfelSlamOptions last_pose;
  last_pose.constant_velocity_guess = false;
  ASSERT_TRUE(SurfelSlamOptions{}.constant_velocity_guess);
  const RunOutput cv = run_sequence(uri, kFrames, {});
  const RunOutput lp = run_sequence(uri, kFrames, last_pose);
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(cv, kFrames));
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(lp, kFrames));
  const double ate_cv = ate_rmse(cv), ate_lp = ate_rmse(lp);
  std::printf("constant velocity: ATE %.2f mm, %lld Gauss-Newton steps; last pose: ATE %.2f mm, %lld steps\n",
              ate_cv * 1e3, static_cast<long long>(cv.gauss_newton_steps), ate_lp * 1e3,
              static_cast<long long>(lp.gauss_newton_steps));
  EXPECT_LT(ate_cv, 0.01);  // metres
  EXPECT_LT(cv.gauss_newton_steps, lp.gauss_newton_steps);
}

// Reordering the pool changes surfel ids, and with them the order in which fusion meets candidates
// of equal rank, but not what is mapped: the same sequence with and without it tracks as well and
// makes a map of about the same size.
TEST(SurfelSlam, SpatialReorderingKeepsTrackingAndMap) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  constexpr int kFrames = test::frames_native_or_emulated(40, 20);
  SurfelSlamOptions never, often;
  never.spatial_order.every_frames = 0;
  often.spatial_order.every_frames = 3;
  const std::string uri = "synthetic:office?noise=1&frames=1000&size=320x240";
  const RunOutput a = run_sequence(uri, kFrames, never);
  const RunOutput b = run_sequence(uri, kFrames, often);
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(a, kFrames));
  ASSERT_NO_FATAL_FAILURE(expect_every_frame_tracked(b, kFrames));
  const double ate_a = ate_rmse(a), ate_b = ate_rmse(b);
  EXPECT_LT(ate_b, 0.01);
  EXPECT_NEAR(ate_b, ate_a, 0.002);  // metres
  EXPECT_NEAR(static_cast<double>(b.surfels), static_cast<double>(a.surfels), 0.03 * static_cast<double>(a.surfels));
  // The pool's block bounds (slam/surfel_pool.h) are recomputed by a reorder and nothing else: the
  // per-frame writers (fusion, removal, new surfels) keep them current without a pass over the pool.
  EXPECT_EQ(a.bounds_refreshes, 0u);
  EXPECT_GT(b.reorders, 0);
  EXPECT_EQ(b.bounds_refreshes, static_cast<uint64_t>(b.reorders));
  std::printf("never reordered: ATE %.2f mm, %lld surfels; every 3 frames: ATE %.2f mm, %lld surfels\n", ate_a * 1e3,
              static_cast<long long>(a.surfels), ate_b * 1e3, static_cast<long long>(b.surfels));
}

// A pipeline preprocesses frames on another thread, into Preprocessors of its own: the same frames
// given preprocessed to a SLAM without its own preprocessor give the same poses and map.
TEST(SurfelSlam, PreprocessedFramesGiveTheSameResultAsProcessingInside) {
  auto src = open_source("synthetic:office?frames=12&size=160x120");
  ASSERT_TRUE(src.ok());
  const Intrinsics K = (*src)->info().intrinsics;
  auto inside = SurfelSlam::create(K);
  SurfelSlamOptions o;
  o.own_preprocessor = false;
  auto outside = SurfelSlam::create(K, o);
  ASSERT_TRUE(inside.ok() && outside.ok());
  auto pre = outside->make_preprocessor();
  ASSERT_TRUE(pre.ok()) << to_string(pre.error());
  Frame frame;
  frame.allocate(K.width, K.height, false);
  SlamFrameResult a, b;
  // Without its own preprocessor, process(frame) is an error naming the way to call it.
  ASSERT_TRUE(*(*src)->next(frame));
  const Status refused = outside->process(frame, &b);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("own_preprocessor"), std::string::npos) << refused.error().message;
  for (int i = 0; i < 12; ++i) {
    if (i > 0) {
      ASSERT_TRUE(*(*src)->next(frame));
    }
    ASSERT_TRUE(inside->process(frame, &a).ok());
    ASSERT_TRUE(pre->process(frame).ok());
    ASSERT_TRUE(outside->process(frame, *pre, &b).ok());
    EXPECT_EQ(a.T_world_cam.matrix(), b.T_world_cam.matrix()) << "frame " << i;
    EXPECT_EQ(b.timings.preprocess_ms, 0.0);
  }
  EXPECT_EQ(inside->pool().size(), outside->pool().size());
  EXPECT_GT(outside->pool().size(), 1000);
  // A preprocessor of another size is refused.
  auto small = Preprocessor::create(K.scaled_to(K.width / 2, K.height / 2));
  ASSERT_TRUE(small.ok());
  const Status wrong = outside->process(frame, *small, &b);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("preprocessed frame is 80x60"), std::string::npos) << wrong.error().message;
}

TEST(SurfelSlam, InvalidOptionsAreRejectedNamingTheField) {
  const Intrinsics K = Intrinsics{585, 585, 320, 240, 640, 480}.scaled_to(320, 240);
  SurfelSlamOptions o;
  EXPECT_TRUE(o.validate().ok());
  o.fusion.stable_confidence = 5.0f;  // prediction keeps 10
  auto r = SurfelSlam::create(K, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("stable_confidence"), std::string::npos) << r.error().message;
  o = {};
  o.preprocess.levels = 1;  // fusion reads normals of level 1
  r = SurfelSlam::create(K, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("normal_level"), std::string::npos) << r.error().message;
  o = {};
  o.pool.capacity = 0;
  r = SurfelSlam::create(K, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("capacity"), std::string::npos) << r.error().message;
}

// Frames of one source at the working resolution, on demand.
class WorkingFrames {
 public:
  explicit WorkingFrames(const std::string& uri) {
    auto src = open_source(uri);
    EXPECT_TRUE(src.ok()) << to_string(src.error());
    if (!src.ok()) return;
    src_ = std::move(*src);
    input_.allocate(src_->info().intrinsics.width, src_->info().intrinsics.height, src_->info().has_labels);
    frame_.allocate(320, 240, src_->info().has_labels);
  }
  Intrinsics intrinsics() const { return src_->info().intrinsics.scaled_to(320, 240); }
  const Frame* next() {
    auto got = src_->next(input_);
    if (!got.ok() || !*got) return nullptr;
    resample_frame(input_, frame_);
    return &frame_;
  }

 private:
  std::unique_ptr<FrameSource> src_;
  Frame input_, frame_;
};

// FNV-1a over every column of the pool's live surfels: "the map is untouched".
uint64_t pool_hash(const SurfelPool& p) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* data, std::size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  const auto n = static_cast<std::size_t>(p.size());
  for (const float* c : {p.x(), p.y(), p.z(), p.nx(), p.ny(), p.nz(), p.radius(), p.confidence()}) mix(c, n * 4);
  mix(p.color(), n * 4);
  mix(p.init_time(), n * 4);
  mix(p.last_seen(), n * 4);
  mix(p.labels(), n * SurfelPool::kLabelBytesPerSurfel);
  mix(&n, sizeof n);
  return h;
}

TEST(SurfelSlam, FrameOfAnotherSceneIsLostAndLeavesTheMapUntouched) {
  WorkingFrames office("synthetic:office?noise=1&frames=1000&size=320x240");
  WorkingFrames kitchen("synthetic:kitchen?noise=1&frames=1000&size=320x240&seed=5");
  auto slam = SurfelSlam::create(office.intrinsics());
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  SlamFrameResult r;
  for (int i = 0; i < 15; ++i) {
    const Frame* f = office.next();
    ASSERT_NE(f, nullptr);
    ASSERT_TRUE(slam->process(*f, &r).ok());
    ASSERT_FALSE(r.lost) << "frame " << i << ": " << track_lost_reason_name(r.track.reason);
  }
  const uint64_t before = pool_hash(slam->pool());
  const SE3 pose_before = slam->pose();
  const Frame* other = kitchen.next();
  ASSERT_NE(other, nullptr);
  ASSERT_TRUE(slam->process(*other, &r).ok());
  EXPECT_TRUE(r.lost);
  EXPECT_FALSE(r.fused);
  EXPECT_EQ(slam->lost_frames(), 1);
  EXPECT_EQ(pool_hash(slam->pool()), before);
  EXPECT_LT((r.T_world_cam.translation() - pose_before.translation()).norm(), 1e-12);  // the last good pose

  // The office again: tracked against the same model, and mapping goes on.
  const Frame* f = office.next();
  ASSERT_NE(f, nullptr);
  ASSERT_TRUE(slam->process(*f, &r).ok());
  EXPECT_FALSE(r.lost) << track_lost_reason_name(r.track.reason);
  EXPECT_TRUE(r.fused);
}

TEST(SurfelSlam, TinyPoolFillsUpAndCountsRefusedSurfels) {
  WorkingFrames office("synthetic:office?noise=1&frames=1000&size=320x240");
  SurfelSlamOptions options;
  options.pool.capacity = 20000;  // a third of one frame's pixels
  auto slam = SurfelSlam::create(office.intrinsics(), options);
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  SlamFrameResult r;
  int64_t refused = 0;
  for (int i = 0; i < 12; ++i) {
    const Frame* f = office.next();
    ASSERT_NE(f, nullptr);
    ASSERT_TRUE(slam->process(*f, &r).ok());
    refused += r.fusion.refused;
    EXPECT_LE(slam->pool().size(), 20000);
  }
  EXPECT_EQ(slam->pool().size(), 20000);
  EXPECT_GT(refused, 0);
  EXPECT_EQ(static_cast<uint64_t>(refused), slam->pool().counters().refused);
  // Created = live + removed + evicted: every surfel is accounted for.
  const SurfelPoolCounters& c = slam->pool().counters();
  EXPECT_EQ(c.created, static_cast<uint64_t>(slam->pool().size()) + c.removed + c.evicted);
}

// Revisiting: the camera pans one way and back (noise-free renders of a built-in room, 1 degree a
// frame). On the way back, the surface entering the image at its border is surface the map already
// holds: it left the view there on the way out. Associating through an index map at the tracked
// pose finds those surfels; through the previous pose's, those pixels lie outside the index map and
// become new surfels, duplicates of the old ones.
TEST(SurfelSlam, AssociatingAtTheTrackedPoseMakesNoDuplicatesOnTheWayBack) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  constexpr int kOut = test::frames_native_or_emulated(20, 12);  // frames of the way out
  const std::string uri = "synthetic:office?noise=0&frames=1&size=320x240";
  const std::unique_ptr<synth::SyntheticSource> src = test::open_synth(uri);
  ASSERT_NE(src, nullptr);
  const Intrinsics K = src->info().intrinsics;
  ASSERT_EQ(K.width, 320);
  synth::Renderer renderer(src->scene(), K);
  const SE3 start = src->poses()[0];
  Frame frame;
  frame.allocate(K.width, K.height, true);
  int64_t back_new[2] = {0, 0}, surfels[2] = {0, 0};
  for (int tracked = 0; tracked < 2; ++tracked) {
    SurfelSlamOptions options;
    options.associate_at_tracked_pose = tracked == 1;
    auto slam = SurfelSlam::create(K, options);
    ASSERT_TRUE(slam.ok()) << to_string(slam.error());
    SlamFrameResult r;
    for (int i = 0; i <= 2 * kOut; ++i) {
      const int step = i <= kOut ? i : 2 * kOut - i;  // 0 .. kOut .. 0
      Vector6d pan;
      pan << 0, 0, 0, 0, step * M_PI / 180.0, 0;  // about the camera's y axis (down)
      renderer.render(start * SE3::exp(pan), frame.color.view(), frame.depth.view(), frame.labels.view());
      ASSERT_TRUE(slam->process(frame, &r).ok());
      ASSERT_FALSE(r.lost) << "frame " << i << ": " << track_lost_reason_name(r.track.reason);
      EXPECT_EQ(r.timings.index_ms > 0, tracked == 1 && i > 0) << "frame " << i;
      if (i > kOut) back_new[tracked] += r.fusion.new_surfels;
    }
    surfels[tracked] = slam->pool().size();
  }
  std::printf("new surfels on the way back: %lld associating at the previous pose, %lld at the tracked pose; "
              "surfels at the end %lld / %lld\n",
              static_cast<long long>(back_new[0]), static_cast<long long>(back_new[1]),
              static_cast<long long>(surfels[0]), static_cast<long long>(surfels[1]));
  // Each frame of the way back brings about 4.6 pixels' width (1 degree) of known surface into view,
  // of whose pixels the default fuses one in four (FusionOptions::pixel_stride 2).
  const int stride = SurfelSlamOptions{}.fusion.pixel_stride;
  EXPECT_GT(back_new[0], kOut * 3 * K.height / (stride * stride));
  EXPECT_LT(back_new[1] * 4, back_new[0]);
  EXPECT_LT(surfels[1], surfels[0]);
}

TEST(SurfelSlam, NoHeapAllocationPerFrameAfterWarmUp) {
  WorkingFrames office("synthetic:office?noise=1&frames=1000&size=320x240");
  SurfelSlamOptions options;
  options.spatial_order.every_frames = 4;  // the pool's reordering runs on measured frames too
  auto slam = SurfelSlam::create(office.intrinsics(), options);
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  SlamFrameResult r;
  constexpr int kWarmUp = 3, kMeasured = 10;
  std::vector<Frame> frames(kMeasured);
  for (int i = 0; i < kWarmUp; ++i) {
    const Frame* f = office.next();
    ASSERT_NE(f, nullptr);
    ASSERT_TRUE(slam->process(*f, &r).ok());
  }
  for (Frame& copy : frames) {  // decoded beforehand: the source may allocate, SLAM must not
    const Frame* f = office.next();
    ASSERT_NE(f, nullptr);
    copy = *f;
  }
  test::AllocationCounter count;
  for (const Frame& f : frames) ASSERT_TRUE(slam->process(f, &r).ok());
  EXPECT_EQ(count.thread_allocations(), 0u);
  EXPECT_EQ(slam->lost_frames(), 0);
}


// ---- relocalisation (slam/keyframe_ferns.h) ----

// Frames of a sequence kept in memory, so a test can replay them in any order.
std::vector<Frame> load_frames(const std::string& uri, int count) {
  WorkingFrames src(uri);
  std::vector<Frame> frames;
  for (int i = 0; i < count; ++i) {
    const Frame* f = src.next();
    if (f == nullptr) break;
    frames.push_back(*f);
  }
  return frames;
}

// Distance between the estimated pose and the reference, both relative to frame 0.
double pose_error_m(const Frame& first, const Frame& f, const SE3& estimate) {
  const SE3 reference = first.T_wc.inverse() * f.T_wc;
  return (reference.translation() - estimate.translation()).norm();
}

const char* const kOffice600 = "synthetic:office?noise=1&frames=600&size=320x240";

// The camera is carried back to where it started (a kidnap): the frame after the jump is lost by
// the normal tracking, looked up among the keyframes and found again at the right place.
TEST(SurfelSlam, KidnappedCameraIsRelocalisedAtAKeyframe) {
  // The short form (qemu, sanitizers) takes the same path at twice the speed, 23 frames: 45 frames of
  // the 600-frame path were the longest test under qemu (58 s, stop 49). The short form passes
  // natively too.
  constexpr int kBefore = test::frames_native_or_emulated(90, 23);
  const char* const uri = test::kShortForm ? "synthetic:office?noise=1&frames=300&size=320x240" : kOffice600;
  const std::vector<Frame> frames = load_frames(uri, kBefore);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kBefore));
  for (bool relocalisation : {true, false}) {
    if (!relocalisation && test::kShortForm) break;  // the contrast only in the release build (time)
    SurfelSlamOptions options;
    options.relocalisation = relocalisation;
    auto slam = SurfelSlam::create(WorkingFrames(uri).intrinsics(), options);
    ASSERT_TRUE(slam.ok()) << to_string(slam.error());
    SlamFrameResult r;
    for (int i = 0; i < kBefore; ++i) {
      ASSERT_TRUE(slam->process(frames[i], &r).ok());
      ASSERT_FALSE(r.lost) << "frame " << i;
    }
    EXPECT_GE(slam->keyframes().size(), 2);
    const double moved = pose_error_m(frames[2], frames[kBefore - 1], SE3());
    // Back to frames 2, 3, ...: the first of them must not be fused at a wrong pose.
    int resumed_at = -1;
    double worst_after = 0;
    for (int i = 2; i < 12; ++i) {
      ASSERT_TRUE(slam->process(frames[i], &r).ok());
      if (!r.lost && resumed_at < 0) resumed_at = i;
      if (!r.lost) worst_after = std::max(worst_after, pose_error_m(frames[0], frames[i], r.T_world_cam));
    }
    if (relocalisation) {
      EXPECT_GT(moved, 0.1) << "the jump must be a real one";
      EXPECT_GE(resumed_at, 2);
      EXPECT_LE(resumed_at, 4) << "relocalised within 3 frames of the jump";
      // The estimate had drifted 1-2 cm on the way (noisy depth); the jump back was 1 m.
      EXPECT_LT(worst_after, 0.04);
      EXPECT_EQ(slam->relocalisations(), 1);
    } else {
      // Without it, the camera is never found again (or only at a wrong place).
      EXPECT_TRUE(resumed_at < 0 || worst_after > 0.05) << resumed_at << " " << worst_after;
    }
  }
}

// A covered lens: frames of zero depth and black colour. Each is lost, nothing is fused (the map is
// untouched), and the first real frame after them resumes tracking from the last good pose.
TEST(SurfelSlam, CoveredLensIsLostWithoutGhostsThenResumed) {
  constexpr int kBefore = test::frames_native_or_emulated(20, 10), kBlank = 10;
  const std::vector<Frame> frames = load_frames(kOffice600, kBefore + 3);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kBefore + 3));
  auto slam = SurfelSlam::create(WorkingFrames(kOffice600).intrinsics());
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  SlamFrameResult r;
  for (int i = 0; i < kBefore; ++i) ASSERT_TRUE(slam->process(frames[i], &r).ok());
  ASSERT_EQ(slam->lost_frames(), 0);
  const double drift = pose_error_m(frames[0], frames[kBefore - 1], r.T_world_cam);  // before the loss
  Frame blank = frames[0];
  blank.depth.fill(0.0f);
  blank.color.fill(Rgb8{0, 0, 0});
  const uint64_t before = pool_hash(slam->pool());
  const uint64_t created = slam->pool().counters().created;
  for (int i = 0; i < kBlank; ++i) {
    ASSERT_TRUE(slam->process(blank, &r).ok());
    EXPECT_TRUE(r.lost);
    EXPECT_FALSE(r.fused);
  }
  EXPECT_EQ(pool_hash(slam->pool()), before);
  EXPECT_EQ(slam->pool().counters().created, created) << "surfels created during the loss";
  for (int i = kBefore; i < kBefore + 3; ++i) {
    ASSERT_TRUE(slam->process(frames[i], &r).ok());
    EXPECT_FALSE(r.lost) << "frame " << i << ": " << track_lost_reason_name(r.track.reason);
    if (i == kBefore) {
      EXPECT_TRUE(r.relocalised);
      EXPECT_EQ(r.lost_before, kBlank);
    }
    EXPECT_LT(pose_error_m(frames[0], frames[i], r.T_world_cam), drift + 0.005) << "frame " << i;
  }
  EXPECT_EQ(slam->lost_frames(), kBlank);
  EXPECT_EQ(slam->relocalisations(), 1);
}

// Looking up keyframes and tracking against them allocates nothing either.
TEST(SurfelSlam, NoHeapAllocationWhenRelocalising) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  const std::vector<Frame> frames = load_frames(kOffice600, 40);
  ASSERT_EQ(frames.size(), 40u);
  auto slam = SurfelSlam::create(WorkingFrames(kOffice600).intrinsics());
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  SlamFrameResult r;
  for (int i = 0; i < 40; ++i) ASSERT_TRUE(slam->process(frames[i], &r).ok());
  Frame blank = frames[0];
  blank.depth.fill(0.0f);
  blank.color.fill(Rgb8{0, 0, 0});
  int64_t relocalised_at_keyframe = 0;
  test::AllocationCounter count;
  for (int i : {0, 1, 2}) {  // the jump back, found again at a keyframe
    ASSERT_TRUE(slam->process(frames[i], &r).ok());
    relocalised_at_keyframe += r.keyframe >= 0 ? 1 : 0;
  }
  ASSERT_TRUE(slam->process(blank, &r).ok());  // lost: no data
  ASSERT_TRUE(slam->process(frames[3], &r).ok());
  EXPECT_EQ(count.thread_allocations(), 0u);
  EXPECT_GE(relocalised_at_keyframe, 1);
}

// Loop closure on a short time window (ElasticFusion's active-only association): a pan out and back
// (1 degree a frame) over noise-free renders, so that the way back sees surface last seen more than `window` frames
// before, the inactive model. The check registers against it; with no drift to remove, the
// registrations move the camera by less than the minimum correction and close nothing. With that
// minimum at 0 every registration becomes a closure: each meets its constraints, and the trajectory
// stays as accurate.
TEST(SurfelSlam, LoopChecksRegisterAgainstTheInactiveModelAndCloseOnlyWhatIsOpen) {
  // Needs 32 frames out (a shorter pan leaves too little inactive surface in view to register: the
  // default map, every other pixel fused, covers fewer pixels of it than every pixel's, which
  // registered from 24 on): about 2.5 minutes under qemu-user, for code that the other tests already
  // run there.
  if (test::kUnderEmulator) GTEST_SKIP() << "native only: 100 rendered and mapped frames";
  constexpr int kOut = 32;
  const std::string uri = "synthetic:office?noise=0&frames=1&size=320x240";
  const std::unique_ptr<synth::SyntheticSource> src = test::open_synth(uri);
  ASSERT_NE(src, nullptr);
  const Intrinsics K = src->info().intrinsics;
  synth::Renderer renderer(src->scene(), K);
  const SE3 start = src->poses()[0];
  Frame frame;
  frame.allocate(K.width, K.height, true);
  int registered[2] = {0, 0}, closed[2] = {0, 0};
  double worst[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    SurfelSlamOptions options;
    options.associate_active_only = true;
    options.prediction.active_window_frames = 8;
    options.loop_check_every = 1;
    if (run == 1) options.loop_min_correction_m = options.loop_min_correction_deg = 0.0f;
    auto slam = SurfelSlam::create(K, options);
    ASSERT_TRUE(slam.ok()) << to_string(slam.error());
    SlamFrameResult r;
    for (int i = 0; i <= 2 * kOut; ++i) {
      const int step = i <= kOut ? i : 2 * kOut - i;
      Vector6d pan;
      pan << 0, 0, 0, 0, step * M_PI / 180.0, 0;
      const SE3 truth = start * SE3::exp(pan);
      renderer.render(truth, frame.color.view(), frame.depth.view(), frame.labels.view());
      ASSERT_TRUE(slam->process(frame, &r).ok());
      ASSERT_FALSE(r.lost) << "frame " << i;
      registered[run] += r.loop_registered ? 1 : 0;
      if (r.loop_accepted) {
        ++closed[run];
        EXPECT_LE(r.deformation.rms_after_m, options.loop_max_residual_m);
      }
      worst[run] = std::max(worst[run], ((start.inverse() * truth).translation() - r.T_world_cam.translation()).norm());
    }
    // Every frame's pose is held (pose history): without closures as reported; with them, each
    // corrected by the closures after it. These closures are forced at noise level (no drift to
    // remove), so they move the map's frame by a few millimetres: the corrected poses stay within
    // 1 cm more of the truth than the tracked ones (measured: 8 mm at worst, against 2.7).
    const PoseHistory& history = slam->pose_history();
    ASSERT_EQ(history.size(), 2 * kOut + 1);
    EXPECT_EQ(history.deformations(), closed[run]);
    SE3 last;
    ASSERT_TRUE(history.at_frame(2 * kOut, &last));
    EXPECT_EQ(last.translation(), r.T_world_cam.translation());
    for (int i = 0; i <= 2 * kOut; ++i) {
      const int step = i <= kOut ? i : 2 * kOut - i;
      Vector6d pan;
      pan << 0, 0, 0, 0, step * M_PI / 180.0, 0;
      SE3 held;
      ASSERT_TRUE(history.at_frame(i, &held));
      EXPECT_LT((SE3::exp(pan).translation() - held.translation()).norm(), worst[run] + (run == 0 ? 1e-12 : 0.01))
          << "run " << run << " frame " << i;
    }
  }
  std::printf("loop checks: registered %d / %d, closed %d / %d; worst position error %.4f / %.4f m\n", registered[0],
              registered[1], closed[0], closed[1], worst[0], worst[1]);
  EXPECT_GT(registered[0], 3);
  EXPECT_EQ(closed[0], 0);
  EXPECT_GT(closed[1], 3);
  EXPECT_LT(worst[1], worst[0] + 0.002);
}
}  // namespace
}  // namespace ef::slam
