#include "pipeline/capture_thread.h"

#include <cstdio>
#include <string>

#include "platform/cpu/thread_affinity.h"

namespace ef::pipeline {

namespace {
int64_t micros_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t).count();
}
}  // namespace

CaptureThread::CaptureThread(FrameSource& source, int slots)
    : source_(source), ring_(slots, [&source](CapturedFrame& slot) {
        const SourceInfo& info = source.info();
        slot.frame.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
      }) {}

CaptureThread::~CaptureThread() { stop(); }

void CaptureThread::start(int cpu) {
  if (thread_.joinable()) return;
  thread_ = std::thread([this, cpu] {
    pin_current_thread_or_warn(cpu, "capture");
    produce();
  });
}

void CaptureThread::stop() {
  request_stop();
  if (thread_.joinable()) thread_.join();
  ring_.close();
}

void CaptureThread::produce() {
  while (true) {
    const auto t0 = std::chrono::steady_clock::now();
    CapturedFrame& slot = ring_.acquire_write();
    int64_t handoff = micros_since(t0);
    slot.end = false;
    slot.error.reset();
    if (stop_.load(std::memory_order_relaxed)) {
      slot.end = true;  // stopped by the consumer: an end marker, nothing more captured
      ring_.commit();
      return;
    }
    auto got = source_.next(slot.frame);
    const auto t1 = std::chrono::steady_clock::now();
    if (!got.ok() && got.error().code == ErrorCode::kCorruptData) {
      // One bad frame of the camera: dropped, counted, capture goes on.
      ring_.abort_write();
      corrupt_dropped_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    const bool ended = !got.ok() || !*got;
    if (ended) {
      slot.end = true;
      if (!got.ok()) slot.error = got.error();
    }
    ring_.commit();  // the slot belongs to the consumer from here on
    handoff += micros_since(t1);
    if (handoff > max_handoff_us_.load(std::memory_order_relaxed))
      max_handoff_us_.store(handoff, std::memory_order_relaxed);
    if (ended) return;
  }
}

}  // namespace ef::pipeline
