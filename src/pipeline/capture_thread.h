// Capture on its own thread for live cameras: the camera is read as fast as it delivers, into a
// FrameRing of preallocated slots (core/frame_ring.h), and the mapper takes frames from the ring.
// The camera is never blocked by processing: when the ring is full the oldest waiting frame is
// dropped and counted (FrameRing::dropped()). Replays do not use it: a recording waits for the
// mapper and loses nothing.
//
// A frame the source reports corrupt (kCorruptData) is skipped and counted; capture goes on.
// The end of the stream and any other source error travel through the ring as the last slot (`end` set,
// `error` holding the error if any), after every frame before them, so the consumer sees them in
// order and nothing already captured is lost by stopping.
//
// Threads: start() launches the capture thread (the producer); the caller is the consumer. stop()
// asks the thread to finish after the frame in hand (a camera read returns within its timeout) and
// joins it; the destructor stops too. Memory: the ring's slots are allocated by the constructor.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <thread>

#include "core/frame.h"
#include "core/frame_ring.h"
#include "core/result.h"
#include "io/frame_source.h"

namespace ef::pipeline {

struct CapturedFrame {
  Frame frame;
  bool end = false;            // no frame: the stream ended (error empty) or failed (error set)
  std::optional<Error> error;  // the source's error, when end
};

class CaptureThread {
 public:
  // source: borrowed, must outlive this object and not be used by anyone else meanwhile.
  // slots: ring capacity (>= 2); each slot is sized for the source's frames.
  CaptureThread(FrameSource& source, int slots);
  // What the constructor allocates: `slots` frames of width x height (with labels when the source
  // has them).
  static std::size_t bytes_for(int slots, int width, int height, bool with_labels) {
    return std::size_t(slots) * Frame::bytes_for(width, height, with_labels);
  }
  ~CaptureThread();
  CaptureThread(const CaptureThread&) = delete;
  CaptureThread& operator=(const CaptureThread&) = delete;

  // Launches the capture thread, pinned to CPU core `cpu` when >= 0 (a failure to pin is a warning
  // on stderr: capture still runs).
  void start(int cpu = -1);
  // Asks the producer to stop after the frame in hand; it then commits the end marker. Returns at
  // once: the frames already captured stay in the ring for the consumer. Any thread.
  void request_stop() { stop_.store(true, std::memory_order_relaxed); }
  // request_stop(), then joins the thread and closes the ring. Idempotent.
  void stop();

  // Consumer: the oldest captured slot, waiting up to `timeout`; nullptr on time-out. The slot
  // must be given back with release() before the next acquire().
  CapturedFrame* acquire(std::chrono::microseconds timeout) { return ring_.acquire_read(timeout); }
  void release() { ring_.release(); }

  uint64_t dropped() const { return ring_.dropped(); }      // frames dropped because the ring was full
  uint64_t captured() const { return ring_.committed(); }   // slots committed (frames + the end marker)
  // Frames the source reported corrupt (kCorruptData): skipped by the producer, capture went on.
  uint64_t corrupt_dropped() const { return corrupt_dropped_.load(std::memory_order_relaxed); }
  // Longest time one pass of the producer spent outside the source's next() (acquiring and
  // committing a slot), microseconds: how long capture was ever held up by the consumer.
  int64_t max_handoff_us() const { return max_handoff_us_.load(std::memory_order_relaxed); }

 private:
  void produce();

  FrameSource& source_;
  FrameRing<CapturedFrame> ring_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> max_handoff_us_{0};
  std::atomic<uint64_t> corrupt_dropped_{0};
  std::thread thread_;
};

}  // namespace ef::pipeline
