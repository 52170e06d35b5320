#include "pipeline/front_stage.h"

#include <thread>

#include "core/stopwatch.h"
#include "io/frame_resample.h"

namespace ef::pipeline {

namespace {
// How long one step() waits for a live camera's next frame before it returns kNothingYet, so that
// the caller can look at its stop requests (signals, the button) between frames.
constexpr std::chrono::milliseconds kCaptureWait(200);
}  // namespace

Result<std::unique_ptr<FrontStage>> FrontStage::create(const RunOptions& run, const PipelineOptions& pipeline,
                                                       FrameSource& source, const slam::SurfelSlam& slam,
                                                       RunSemantics* semantics) {
  std::unique_ptr<FrontStage> f(new FrontStage(run, pipeline, source, slam, semantics));
  const SourceInfo& info = source.info();
  if (info.live) {
    f->capture_ = std::make_unique<CaptureThread>(source, pipeline.capture_slots);
  } else {
    f->input_.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  }
  return f;
}

FrontStage::~FrontStage() {
  if (capture_ != nullptr) capture_->stop();
}

Status FrontStage::allocate(PreparedFrame& slot) const {
  const SourceInfo& info = source_.info();
  slot.working.allocate(run_.resolution.width, run_.resolution.height, info.has_labels);
  auto pre = slam_.make_preprocessor();
  if (!pre.ok()) return pre.take_error();
  slot.pre.emplace(std::move(*pre));
  return Status::success();
}

Status FrontStage::resume_at(int64_t frames) {
  if (capture_ == nullptr) {
    auto skipped = source_.skip(frames, input_);
    if (!skipped.ok()) return skipped.error();
    if (*skipped < frames)
      return error(ErrorCode::kInvalidArgument, source_.info().uri + " has " + std::to_string(*skipped) +
                                                    " frames; the checkpoint continues after frame " +
                                                    std::to_string(frames) + " (a different recording?)");
  }
  delivered_ = frames;
  return Status::success();
}

void FrontStage::start_capture() {
  if (capture_ != nullptr) capture_->start(pipeline_.capture_cpu);
}

FrontStage::Step FrontStage::end(PreparedFrame& slot, std::optional<Error> error) {
  slot.end = true;
  slot.error = std::move(error);
  slot.number = delivered_;
  ended_ = true;
  if (cnn_request_) {  // a label update the CNN never got to
    cnn_skipped_.fetch_add(1, std::memory_order_relaxed);
    cnn_request_ = false;
  }
  if (capture_ != nullptr) capture_->stop();  // joins: the camera is released as soon as possible
  return Step::kEnd;
}

void FrontStage::pace(double timestamp) {
  // Recorded speed: frame k is released no earlier than (t_k - t_0) after the first one.
  if (delivered_ == 0) {
    replay_wall_start_ = std::chrono::steady_clock::now();
    replay_t0_ = timestamp;
    return;
  }
  const auto due = replay_wall_start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                            std::chrono::duration<double>(timestamp - replay_t0_));
  const double behind = std::chrono::duration<double>(std::chrono::steady_clock::now() - due).count();
  if (behind > kRealtimeLateSeconds) {
    // The machine does not keep up with the recording: the frame goes out late (never dropped:
    // a replay loses nothing), and that is counted.
    late_frames_.fetch_add(1, std::memory_order_relaxed);
    const int64_t ms = static_cast<int64_t>(behind * 1000.0);
    if (ms > max_late_ms_.load(std::memory_order_relaxed)) max_late_ms_.store(ms, std::memory_order_relaxed);
    return;
  }
  std::this_thread::sleep_until(due);
}

FrontStage::Step FrontStage::step(PreparedFrame& slot) {
  slot.end = false;
  slot.error.reset();
  slot.cnn_wait = false;
  if (ended_) return end(slot, std::nullopt);
  if (run_.frames >= 0 && delivered_ >= run_.frames) return end(slot, std::nullopt);

  const SteadyClock::time_point t_source = SteadyClock::now();
  const Frame* captured = nullptr;
  CapturedFrame* captured_slot = nullptr;
  if (capture_ != nullptr) {
    // The capture thread went on after a stop request until its end marker: every frame it had
    // captured comes out first.
    captured_slot = capture_->acquire(kCaptureWait);
    if (captured_slot == nullptr) return Step::kNothingYet;
    if (captured_slot->end) {
      std::optional<Error> e = captured_slot->error;
      capture_->release();
      return end(slot, std::move(e));
    }
    captured = &captured_slot->frame;
  } else {
    if (stop_.load(std::memory_order_relaxed)) return end(slot, std::nullopt);
    auto got = source_.next(input_);
    if (!got.ok()) return end(slot, got.error());
    if (!*got) return end(slot, std::nullopt);
    captured = &input_;
    if (run_.realtime) pace(input_.timestamp);
  }
  slot.source_ms = ms_since(t_source);
  slot.logged = log_ != nullptr;
  if (log_ != nullptr) {
    const SteadyClock::time_point t_log = SteadyClock::now();
    (void)log_->log_frame(*captured, *log_encoder_);  // its first error is kept and reported at the end
    slot.log_ms = ms_since(t_log);
  }

  SteadyClock::time_point t0 = SteadyClock::now();
  resample_frame(*captured, slot.working);
  slot.resample_ms = ms_since(t0);
  if (captured_slot != nullptr) capture_->release();  // the camera's slot is free again

  slot.number = delivered_;
  t0 = SteadyClock::now();
  const Status s = slot.pre->process(slot.working);
  slot.preprocess_ms = ms_since(t0);
  if (!s.ok()) return end(slot, s.error());
  ++delivered_;
  if (cnn_ != nullptr) request_cnn(slot);
  return Step::kFrame;
}

void FrontStage::request_cnn(PreparedFrame& slot) {
  const int64_t n = slot.number;
  const bool update = semantics_->fusion_due(n), image = semantics_->image_due(n);
  if (deterministic_) {
    if (update || image) slot.cnn_wait = cnn_->offer(slot.working, n, update, /*wait=*/true);
    return;
  }
  if (update) {
    if (cnn_request_) cnn_skipped_.fetch_add(1, std::memory_order_relaxed);
    cnn_request_ = true;
  }
  if (image) {
    // A label image needs this frame's own result: queued even if that waits.
    slot.cnn_wait = cnn_->offer(slot.working, n, cnn_request_, /*wait=*/true);
    if (slot.cnn_wait) cnn_request_ = false;
  } else if (cnn_request_ && cnn_->offer(slot.working, n, /*fuse=*/true, /*wait=*/false)) {
    cnn_request_ = false;
  }
}

}  // namespace ef::pipeline
