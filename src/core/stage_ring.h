// A ring of preallocated slots that each pass through a fixed sequence of pipeline stages, in order:
//
//   free -> stage 0 -> stage 1 -> ... -> stage S-1 -> free
//
// Every stage runs on one thread (or several stages on one thread, in order) and takes the slots in
// sequence: stage s works on slot number n only after stage s-1 released it, and stage 0 reuses a
// slot only after the last stage released it. So the slots come out of the last stage in the order
// stage 0 filled them, nothing is ever dropped or copied, and a slow stage holds up the ones before
// it once the ring is full (back-pressure). For a live camera, whose frames must not wait, the
// capture thread sits in front of stage 0 with a drop-oldest FrameRing (core/frame_ring.h).
//
// Threads: acquire(s) / release(s) from the thread of stage s; close() from any thread. The mutex
// guards only the cursors; a stage works on its slot without holding it. No heap allocation after
// construction.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>

namespace ef {

template <class T>
class StageRing {
 public:
  // capacity: slots (>= 1); stages: >= 1. init(slot) sizes each slot once.
  template <class Init>
  StageRing(int capacity, int stages, Init&& init)
      : capacity_(capacity < 1 ? 1 : capacity),
        stages_(stages < 1 ? 1 : stages),
        slots_(new T[capacity_]),
        done_(new int64_t[stages_]()) {
    for (int i = 0; i < capacity_; ++i) init(slots_[i]);
  }
  StageRing(const StageRing&) = delete;
  StageRing& operator=(const StageRing&) = delete;

  int capacity() const { return capacity_; }
  int stages() const { return stages_; }

  // Stage s: its next slot, waiting up to `timeout` until the stage before has released it (stage
  // 0: until the last stage has freed it). nullptr on time-out or once the ring is closed. Calling
  // again before release() returns the same slot.
  T* acquire(int stage, std::chrono::microseconds timeout) {
    if (timeout > kMaxWait) timeout = kMaxWait;
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, timeout, [&] { return closed_ || ready_locked(stage); });
    if (closed_ || !ready_locked(stage)) return nullptr;
    return &slots_[done_[stage] % capacity_];
  }

  // Stage s: passes its slot on to stage s+1 (the last stage: frees it for stage 0).
  void release(int stage) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++done_[stage];
    }
    cv_.notify_all();
  }

  // Every waiting and later acquire() returns nullptr (a stage failed; the pipeline stops).
  void close() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      closed_ = true;
    }
    cv_.notify_all();
  }
  bool closed() const {
    std::lock_guard<std::mutex> lock(mu_);
    return closed_;
  }
  // Slots stage s has released so far.
  int64_t released(int stage) const {
    std::lock_guard<std::mutex> lock(mu_);
    return done_[stage];
  }

 private:
  // Bound on waits: wait_for adds the timeout to the clock in nanoseconds, which overflows (and
  // returns at once) for "forever" values such as microseconds::max().
  static constexpr std::chrono::microseconds kMaxWait = std::chrono::hours(24 * 365);

  bool ready_locked(int stage) const {
    if (stage == 0) return done_[0] - done_[stages_ - 1] < capacity_;
    return done_[stage] < done_[stage - 1];
  }

  const int capacity_;
  const int stages_;
  std::unique_ptr<T[]> slots_;
  std::unique_ptr<int64_t[]> done_;  // per stage: slots released, monotonic
  bool closed_ = false;
  mutable std::mutex mu_;
  std::condition_variable cv_;
};

}  // namespace ef
