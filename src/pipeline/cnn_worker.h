// The CNN beside the pipeline (pipeline/run_pipeline.h): a network that costs tens of
// milliseconds must not hold the mapper back, so the front stage hands frames to it and the mapping
// stage picks its results up when they are done.
//
//   front thread     offer(): the working frame (colour, depth, name) copied into a free job;
//                    without wait, nothing happens when both jobs are taken (the CNN is busy)
//   CNN thread       runs the queued jobs, oldest frame first (RunSemantics::segment)
//   mapping thread   take(): a finished job whose frame has been mapped, to be fused at that
//                    frame's pose; release() frees it
//
// Without a thread (pipeline.threads 1) offer() runs the CNN at once on the caller's thread, so
// every job is finished when it is queued: the order of today's single-threaded run.
//
// Memory: create() allocates kJobs jobs (a working frame without labels and a CnnResult each);
// nothing after. Threads: offer() on one thread, take()/release() on one (another) thread, close()
// from the owner; the job a caller holds is its own until it gives it back.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "core/frame.h"
#include "core/result.h"
#include "pipeline/run_semantics.h"

namespace ef::pipeline {

struct CnnJob {
  int64_t number = -1;         // the frame's 0-based number in the run
  bool fuse = false;           // a label update asked for it (else only its label image did)
  Frame frame;                 // the working frame the CNN read (colour, depth, name; no labels)
  CnnResult cnn;               // its result
  std::optional<Error> error;  // the CNN failed on it

  // What CnnWorker::create() allocates per job for a working frame of width x height.
  static std::size_t bytes_for(int width, int height, std::size_t cnn_result_bytes) {
    return Frame::bytes_for(width, height, /*with_labels=*/false) + cnn_result_bytes;
  }
};

class CnnWorker {
 public:
  // Two jobs: one the CNN works on while the other waits to be fused (or is queued behind it).
  static constexpr int kJobs = 2;

  // semantics: borrowed (it owns the network). threaded: the jobs run on a thread of this worker
  // (start()); otherwise offer() runs them at once. test_delay_ms: tests only, a sleep before each
  // job (a slow CNN).
  static Result<std::unique_ptr<CnnWorker>> create(RunSemantics& semantics, int working_width, int working_height,
                                                   bool threaded, double test_delay_ms = 0);
  ~CnnWorker();
  CnnWorker(const CnnWorker&) = delete;
  CnnWorker& operator=(const CnnWorker&) = delete;

  // Starts the thread (threaded workers), pinned to `cpu` when >= 0.
  void start(int cpu);
  // Front thread: queues frame `number` (copied); `fuse`: its result is to be fused into the map.
  // Returns false when no job was free (wait: only once closed). Allocates nothing.
  bool offer(const Frame& working, int64_t number, bool fuse, bool wait);
  // Mapping thread: the finished job with the lowest number <= up_to, or null when there is none.
  // When a job for frame `wait_for` (>= 0) is queued or running, waits for it first.
  CnnJob* take(int64_t up_to, int64_t wait_for);
  void release(CnnJob* job);
  // True while a job for a frame <= up_to is queued or running (the end of a run drains them).
  bool pending(int64_t up_to) const;
  // Stops the thread after its current job; offer() and take() no longer wait.
  void close();

  // Bytes of the jobs (what create() allocated).
  std::size_t bytes() const;

 private:
  enum class State { kFree, kQueued, kRunning, kDone, kTaken };
  explicit CnnWorker(RunSemantics& semantics) : semantics_(semantics) {}
  void run_job(CnnJob& job);
  void loop();

  RunSemantics& semantics_;
  bool threaded_ = false;
  double test_delay_ms_ = 0;
  CnnJob jobs_[kJobs];
  State state_[kJobs] = {State::kFree, State::kFree};
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool closed_ = false;
  std::thread thread_;
};

}  // namespace ef::pipeline
