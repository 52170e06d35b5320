// The front stage of `edgefusion run` (pipeline/run_pipeline.h): everything a frame needs
// before it meets the map, none of which depends on the map or the pose:
//
//   next frame    a live camera's frame from its capture thread (pipeline/capture_thread.h,
//                 drop-oldest), or a recording's next frame (paced by its timestamps with
//                 --realtime); stops after max_frames
//   resample      to the working resolution (io/frame_resample.h)
//   preprocess    depth filter and pyramids (slam/preprocess.h), with the slot's own Preprocessor
//   CNN request   the frame handed to the CNN (pipeline/cnn_worker.h) on the frames a label update
//                 or a label image is due (RunSemantics::fusion_due / image_due). A label image, and
//                 every due frame of a deterministic run (pipeline.deterministic, or one thread), is
//                 queued even if that waits for a free job, and the mapping waits for its result.
//                 Otherwise a label update waits for the CNN to be free: the next frame it is free
//                 on is taken; a request still waiting when the next one falls due is counted as
//                 skipped (cnn_frames_skipped).
//
// The result is a PreparedFrame slot; the mapping stage takes it from there. Because nothing here
// reads the map, these steps can run ahead of mapping on other threads, and the outputs are the
// same as when every step takes its turn on one thread.
//
// Memory: allocate() sizes a slot once (working frame, pyramids); step() allocates nothing.
// Threads: step() on one thread at a time; request_stop() and the counters from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>

#include "pipeline/capture_thread.h"
#include "pipeline/cnn_worker.h"
#include "core/frame.h"
#include "core/result.h"
#include "io/frame_source.h"
#include "io/mcap_log.h"
#include "pipeline/run_config.h"
#include "pipeline/run_semantics.h"
#include "slam/preprocess.h"
#include "slam/surfel_slam.h"

namespace ef::pipeline {

// One frame on its way from the front stage to the mapping stage.
struct PreparedFrame {
  int64_t number = -1;                    // 0-based count of the frames the front stage delivered
  Frame working;                          // the frame at the working resolution
  std::optional<slam::Preprocessor> pre;  // its pyramids: SurfelSlam::process(working, *pre, ...)
  bool cnn_wait = false;                  // the CNN has this frame queued; mapping waits for its result
  double source_ms = 0;                   // getting the frame (decoding, or waiting for the camera)
  double resample_ms = 0;                 // milliseconds each
  double preprocess_ms = 0;
  double log_ms = 0;                      // the frame written to the field log (io/mcap_log.h)
  bool logged = false;                    // the run has a field log: log_ms was measured
  bool end = false;                       // no frame: the stream ended, the stage was stopped or
  std::optional<Error> error;             // max_frames reached (error empty), or the source failed

  // Bytes of one slot: the working frame and its preprocessor.
  std::size_t bytes() const { return working.bytes() + (pre ? pre->bytes() : 0); }
  // What FrontStage::allocate() sizes: a working frame (with labels when the source has them) and
  // `preprocessor_bytes` (slam::Preprocessor::bytes_for).
  static std::size_t bytes_for(int working_width, int working_height, bool with_labels, std::size_t preprocessor_bytes) {
    return Frame::bytes_for(working_width, working_height, with_labels) + preprocessor_bytes;
  }
};

class FrontStage {
 public:
  // source, slam, semantics: borrowed, must outlive the stage; semantics may be null (no labels).
  // slam only provides make_preprocessor(). A live source gets its capture thread here (started by
  // start_capture()).
  // run: the working resolution, max frames, realtime pacing; pipeline: the capture ring's slots
  // and core.
  static Result<std::unique_ptr<FrontStage>> create(const RunOptions& run, const PipelineOptions& pipeline,
                                                    FrameSource& source, const slam::SurfelSlam& slam,
                                                    RunSemantics* semantics);
  ~FrontStage();
  FrontStage(const FrontStage&) = delete;
  FrontStage& operator=(const FrontStage&) = delete;

  // Sizes one slot (start-up; allocates). Errors: the preprocessor's.
  Status allocate(PreparedFrame& slot) const;

  // Live sources: starts reading the camera on the capture thread (pinned to pipeline.capture_cpu
  // when >= 0). Does nothing for recordings.
  void start_capture();
  // A resumed run (pipeline/checkpoint.h): the next frame is number `frames`. A recording skips its
  // first `frames` frames (read and dropped); a live camera goes on with what it sees now. Before
  // start_capture(). Errors: a recording shorter than that, naming both counts; the source's.
  Status resume_at(int64_t frames);

  enum class Step {
    kFrame,       // `slot` holds the next frame, prepared
    kNothingYet,  // a live camera delivered nothing within 200 ms: call again (after checking stops)
    kEnd,         // `slot` is the end marker (slot.end; slot.error when the source failed)
  };
  Step step(PreparedFrame& slot);
  // Where the CNN requests go (null: no labels); deterministic: every due frame waits (see above).
  // Set once before the first step().
  void set_cnn(CnnWorker* cnn, bool deterministic) {
    cnn_ = cnn;
    deterministic_ = deterministic;
  }
  // The field log (null: none), borrowed: every frame the source delivers is written to it as it
  // comes, before resampling (so the log replays the source itself). Set once before the first
  // step(); makes the stage's encoder (allocates). A log that fails (a full disk) keeps its first
  // error and writes no more; the run reports it with its outputs.
  void set_log(McapFrameLog* log) {
    log_ = log;
    log_encoder_ = log != nullptr ? log->make_encoder() : nullptr;
  }
  // Label updates the CNN was too busy to take (see above).
  uint64_t cnn_skipped() const { return cnn_skipped_.load(std::memory_order_relaxed); }
  // --realtime: frames released more than kRealtimeLateSeconds after their recorded time (the
  // machine does not keep up; a replay delays them, never drops them), and the most behind, ms.
  static constexpr double kRealtimeLateSeconds = 0.1;
  uint64_t realtime_late_frames() const { return late_frames_.load(std::memory_order_relaxed); }
  int64_t realtime_max_late_ms() const { return max_late_ms_.load(std::memory_order_relaxed); }

  // Asks the stage to end: a live camera's capture thread stops, and the frames it had already
  // captured still come out before the end marker; a recording ends at the next step(). Any thread.
  void request_stop() {
    stop_.store(true, std::memory_order_relaxed);
    if (capture_ != nullptr) capture_->request_stop();
  }

  // Live cameras: frames dropped because the capture ring was full, and frames the camera reported
  // corrupt (skipped). 0 for recordings.
  uint64_t dropped_overload() const { return capture_ != nullptr ? capture_->dropped() : 0; }
  uint64_t corrupt_dropped() const { return capture_ != nullptr ? capture_->corrupt_dropped() : 0; }

 private:
  FrontStage(const RunOptions& run, const PipelineOptions& pipeline, FrameSource& source,
             const slam::SurfelSlam& slam, RunSemantics* semantics)
      : run_(run), pipeline_(pipeline), source_(source), slam_(slam), semantics_(semantics) {}
  Step end(PreparedFrame& slot, std::optional<Error> error);
  void pace(double timestamp);
  void request_cnn(PreparedFrame& slot);

  const RunOptions run_;
  const PipelineOptions pipeline_;
  FrameSource& source_;
  const slam::SurfelSlam& slam_;
  RunSemantics* semantics_;
  CnnWorker* cnn_ = nullptr;
  McapFrameLog* log_ = nullptr;
  std::unique_ptr<McapFrameLog::Encoder> log_encoder_;
  bool deterministic_ = false;
  bool cnn_request_ = false;  // a label update is due and the CNN has not taken a frame for it yet
  std::atomic<uint64_t> cnn_skipped_{0};
  std::atomic<uint64_t> late_frames_{0};  // written by the front thread, read by mapping
  std::atomic<int64_t> max_late_ms_{0};
  std::unique_ptr<CaptureThread> capture_;  // live sources only
  Frame input_;                             // a recording's frame at its own size
  std::atomic<bool> stop_{false};
  int64_t delivered_ = 0;
  bool ended_ = false;
  // --realtime: wall time and timestamp (seconds) of the first frame.
  std::chrono::steady_clock::time_point replay_wall_start_;
  double replay_t0_ = 0;
};

}  // namespace ef::pipeline
