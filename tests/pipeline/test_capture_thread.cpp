// The capture thread of live cameras (src/pipeline/capture_thread.h): a camera twice (here ten
// times) as fast as the mapper loses frames to the ring's drop-oldest policy, every one of them is
// accounted for, capture itself is never held up, and the camera's error arrives after its frames.
// In test_core so that it runs under ThreadSanitizer in CI.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "pipeline/capture_thread.h"
#include "io/frame_source.h"

namespace ef {
namespace {

using Clock = std::chrono::steady_clock;

// A live source delivering `frames` small frames, one every `period`, then `final_error` (or the end).
class FakeCamera : public FrameSource {
 public:
  FakeCamera(int frames, std::chrono::microseconds period, std::optional<Error> final_error = std::nullopt)
      : frames_(frames), period_(period), final_error_(std::move(final_error)) {
    info_.uri = "fake:";
    info_.intrinsics = Intrinsics{50, 50, 15.5, 11.5, 32, 24};
    info_.live = true;
  }
  const SourceInfo& info() const override { return info_; }
  Result<bool> next(Frame& out) override {
    if (next_ == 0) start_ = Clock::now();
    if (next_ == frames_) {
      finished_at_ = Clock::now();
      if (final_error_) return *final_error_;
      return false;
    }
    std::this_thread::sleep_until(start_ + period_ * next_);
    out.index = next_;
    out.timestamp = double(next_) * 1e-3;
    out.depth.fill(1.0f);
    ++next_;
    return true;
  }
  // Producer-thread data, read after the capture thread has been joined.
  Clock::time_point start_, finished_at_;

 private:
  SourceInfo info_;
  int frames_;
  std::chrono::microseconds period_;
  std::optional<Error> final_error_;
  int next_ = 0;
};

TEST(CaptureThread, FastCameraDropsOldestFramesAccountsForAllAndNeverWaits) {
  constexpr int kFrames = 100;
  FakeCamera camera(kFrames, std::chrono::milliseconds(1));
  pipeline::CaptureThread capture(camera, 4);
  capture.start();
  int delivered = 0;
  int64_t last_index = -1;
  bool ended = false;
  while (!ended) {
    pipeline::CapturedFrame* slot = capture.acquire(std::chrono::seconds(10));
    ASSERT_NE(slot, nullptr) << "the end marker never came";
    if (slot->end) {
      EXPECT_FALSE(slot->error.has_value());
      ended = true;
    } else {
      EXPECT_GT(slot->frame.index, last_index);  // in order; gaps are the dropped frames
      last_index = slot->frame.index;
      EXPECT_EQ(slot->frame.depth.width(), 32);
      ++delivered;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));  // the mapper: 10x slower
    }
    capture.release();
  }
  capture.stop();
  const double produce_s = std::chrono::duration<double>(camera.finished_at_ - camera.start_).count();
  std::printf("[ capture ] %d of %d frames delivered, %llu dropped; camera done in %.3f s; longest hand-off %lld us\n",
              delivered, kFrames, static_cast<unsigned long long>(capture.dropped()), produce_s,
              static_cast<long long>(capture.max_handoff_us()));
  EXPECT_GT(capture.dropped(), 0u);
  EXPECT_EQ(uint64_t(delivered) + capture.dropped(), uint64_t(kFrames));  // none lost silently
  EXPECT_EQ(capture.captured(), uint64_t(kFrames) + 1);                  // + the end marker
  // A camera that waited for the mapper would need kFrames x 10 ms = 1 s; it runs at its own pace.
  EXPECT_LT(produce_s, 0.5);
}

TEST(CaptureThread, CameraErrorArrivesAfterItsFramesAndStopEndsCapture) {
  FakeCamera camera(5, std::chrono::microseconds(100), error(ErrorCode::kNotFound, "fake: camera lost"));
  pipeline::CaptureThread capture(camera, 8);  // room for every frame: nothing dropped
  capture.start();
  int delivered = 0;
  while (true) {
    pipeline::CapturedFrame* slot = capture.acquire(std::chrono::seconds(10));
    ASSERT_NE(slot, nullptr);
    const bool end = slot->end;
    if (end) {
      ASSERT_TRUE(slot->error.has_value());
      EXPECT_EQ(slot->error->code, ErrorCode::kNotFound);
      EXPECT_NE(slot->error->message.find("camera lost"), std::string::npos);
    } else {
      EXPECT_EQ(slot->frame.index, delivered);
      ++delivered;
    }
    capture.release();
    if (end) break;
  }
  EXPECT_EQ(delivered, 5);
  EXPECT_EQ(capture.dropped(), 0u);

  // stop() while the camera still streams: the thread ends, joins, and a consumer does not hang.
  FakeCamera endless(1'000'000, std::chrono::microseconds(200));
  pipeline::CaptureThread running(endless, 4);
  running.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  running.stop();
  int after = 0;
  while (pipeline::CapturedFrame* slot = running.acquire(std::chrono::milliseconds(0))) {
    const bool end = slot->end;
    running.release();
    ++after;
    if (end) break;
  }
  EXPECT_GE(after, 1);  // at least the end marker
}

}  // namespace
}  // namespace ef
