// Bounded single-producer / single-consumer ring of preallocated slots (the frame queue).
//
// Every slot is allocated once, in the constructor. A slot is in exactly one state:
//   free -> writing (producer, acquire_write) -> ready (commit) -> reading (consumer, acquire_read)
//   -> free (release).
// Only the producer touches a slot while it is `writing` and only the consumer while it is
// `reading`; the mutex guards the state table and the FIFO of ready slots, never the pixel copy,
// so a reader can never see a half-written slot and a slow copy never blocks the other side.
//
// Overload policy: the producer never blocks. When no slot is free, acquire_write() takes back the
// oldest ready (committed, not yet read) slot; that frame is dropped and counted in dropped().
// A frame that the consumer has already acquired is never taken back.
//
// Threads: acquire_write/commit/abort_write from one producer thread; acquire_read/release from one
// consumer thread; the counters and close() from any thread. No heap allocation after construction.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>

namespace ef {

template <class T>
class FrameRing {
 public:
  // capacity: number of slots (at least 2). init(slot) sizes each slot once (e.g. Frame::allocate).
  template <class Init>
  FrameRing(int capacity, Init&& init)
      : capacity_(capacity < 2 ? 2 : capacity),
        slots_(new T[capacity_]),
        state_(new State[capacity_]),
        ready_(new int[capacity_]) {
    for (int i = 0; i < capacity_; ++i) {
      init(slots_[i]);
      state_[i] = State::kFree;
    }
  }
  FrameRing(const FrameRing&) = delete;
  FrameRing& operator=(const FrameRing&) = delete;

  int capacity() const { return capacity_; }

  // Producer: a slot to fill. Never blocks and never fails: drops the oldest ready frame if needed.
  // The producer must commit() or abort_write() before the next acquire_write().
  T& acquire_write() {
    std::lock_guard<std::mutex> lock(mu_);
    int slot = -1;
    for (int i = 0; i < capacity_; ++i) {
      if (state_[i] == State::kFree) { slot = i; break; }
    }
    if (slot < 0) {
      // No free slot: all others are ready or one is being read. With capacity >= 2 and the
      // producer holding none, at least one ready slot exists here.
      slot = pop_ready_locked();
      ++dropped_;
    }
    state_[slot] = State::kWriting;
    writing_ = slot;
    return slots_[slot];
  }

  // Producer: publish the slot from acquire_write() to the consumer.
  void commit() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      state_[writing_] = State::kReady;
      ready_[(ready_head_ + ready_count_) % capacity_] = writing_;
      ++ready_count_;
      ++committed_;
      writing_ = -1;
    }
    cv_.notify_one();
  }

  // Producer: give the slot back unpublished (the source failed to fill it).
  void abort_write() {
    std::lock_guard<std::mutex> lock(mu_);
    state_[writing_] = State::kFree;
    writing_ = -1;
  }

  // Consumer: the oldest ready slot, waiting up to `timeout` for one. nullptr on time-out, or
  // when the ring is closed and drained. The consumer must release() before the next acquire.
  T* acquire_read(std::chrono::microseconds timeout) {
    // Bound the wait: wait_for adds the timeout to the clock in nanoseconds, which overflows (and
    // returns at once) for "forever" values such as microseconds::max().
    constexpr std::chrono::microseconds kMaxWait = std::chrono::hours(24 * 365);
    if (timeout > kMaxWait) timeout = kMaxWait;
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, timeout, [&] { return ready_count_ > 0 || closed_; });
    if (ready_count_ == 0) return nullptr;
    reading_ = pop_ready_locked();
    state_[reading_] = State::kReading;
    return &slots_[reading_];
  }
  T* try_acquire_read() { return acquire_read(std::chrono::microseconds(0)); }

  // Consumer: hand the slot from acquire_read() back for reuse.
  void release() {
    std::lock_guard<std::mutex> lock(mu_);
    state_[reading_] = State::kFree;
    reading_ = -1;
  }

  // No more frames will be committed; a waiting consumer wakes up.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      closed_ = true;
    }
    cv_.notify_all();
  }
  bool closed_and_empty() const {
    std::lock_guard<std::mutex> lock(mu_);
    return closed_ && ready_count_ == 0;
  }

  uint64_t dropped() const { std::lock_guard<std::mutex> lock(mu_); return dropped_; }
  uint64_t committed() const { std::lock_guard<std::mutex> lock(mu_); return committed_; }
  int ready_count() const { std::lock_guard<std::mutex> lock(mu_); return ready_count_; }

 private:
  enum class State : uint8_t { kFree, kWriting, kReady, kReading };

  int pop_ready_locked() {
    const int slot = ready_[ready_head_];
    ready_head_ = (ready_head_ + 1) % capacity_;
    --ready_count_;
    return slot;
  }

  const int capacity_;
  std::unique_ptr<T[]> slots_;
  std::unique_ptr<State[]> state_;
  std::unique_ptr<int[]> ready_;  // FIFO of ready slot indices, oldest at ready_head_
  int ready_head_ = 0;
  int ready_count_ = 0;
  int writing_ = -1;
  int reading_ = -1;
  bool closed_ = false;
  uint64_t dropped_ = 0;
  uint64_t committed_ = 0;
  mutable std::mutex mu_;
  std::condition_variable cv_;
};

}  // namespace ef
