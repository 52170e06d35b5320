// Per-stage timing and named counters for a run, with all storage sized at start-up.
//
// Register stages and counters once (this allocates), then record samples and increments per frame
// without touching the heap. Each stage keeps up to `capacity` samples; past that it keeps a
// uniform random subset (reservoir sampling, a fixed-seed xorshift generator), while count, sum
// and max stay exact. Summaries report milliseconds.
//
// Threads: different stages may be recorded from different threads (one writer per stage);
// counters are atomic. Summaries must not run concurrently with recording.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace ef {

struct StageSummary {
  uint64_t count = 0;    // samples recorded (all of them, not just those kept)
  double median_ms = 0;  // of the kept samples; linear interpolation between order statistics
  double p95_ms = 0;     // same definition as numpy.percentile(..., 95), default method
  double mean_ms = 0;    // exact over all samples
  double max_ms = 0;     // exact over all samples
  double total_ms = 0;   // exact sum
};

class StageStats {
 public:
  static constexpr std::size_t kDefaultCapacity = 4096;
  // capacity: samples kept per stage (e.g. the number of frames of a run, or 4096 as a reservoir).
  explicit StageStats(std::size_t capacity = kDefaultCapacity, std::size_t max_stages = 32,
                      std::size_t max_counters = 64);
  StageStats(const StageStats&) = delete;
  StageStats& operator=(const StageStats&) = delete;

  // Registration (start-up only; allocates). Returns the id, or -1 when the fixed maximum is
  // reached. Registering an existing name returns its id.
  int add_stage(std::string_view name);
  int add_counter(std::string_view name);
  // Id of a name, -1 when unknown.
  int stage_id(std::string_view name) const;
  int counter_id(std::string_view name) const;

  // Hot path, no allocation. Out-of-range ids are ignored.
  void record_ns(int stage, int64_t nanoseconds);
  void record_ms(int stage, double milliseconds);
  void increment(int counter, uint64_t by = 1) {
    if (counter >= 0 && static_cast<std::size_t>(counter) < num_counters_)
      counters_[counter].fetch_add(by, std::memory_order_relaxed);
  }
  void set_counter(int counter, uint64_t value) {
    if (counter >= 0 && static_cast<std::size_t>(counter) < num_counters_)
      counters_[counter].store(value, std::memory_order_relaxed);
  }

  std::size_t num_stages() const { return stages_.size(); }
  std::size_t num_counters() const { return num_counters_; }
  const std::string& stage_name(int id) const { return stages_[id].name; }
  const std::string& counter_name(int id) const { return counter_names_[id]; }
  uint64_t counter(int id) const { return counters_[id].load(std::memory_order_relaxed); }
  std::size_t capacity() const { return capacity_; }
  // Bytes of the samples of `stages` stages and the summary's scratch row (8 bytes per sample).
  static std::size_t bytes_for(std::size_t stages, std::size_t capacity = kDefaultCapacity) {
    return (stages + 1) * capacity * sizeof(double);
  }
  // The same for the stages registered so far.
  std::size_t bytes() const { return bytes_for(stages_.size(), capacity_); }

  // Summary of one stage. Uses a scratch buffer preallocated at construction (no allocation), so it
  // is not thread-safe even though it is const.
  StageSummary summary(int stage) const;

  // Forgets every sample and zeroes the counters; registrations stay.
  void reset();

 private:
  struct Stage {
    std::string name;
    std::unique_ptr<double[]> samples;  // milliseconds, capacity_ of them
    std::size_t kept = 0;
    uint64_t count = 0;
    double sum_ms = 0;
    double max_ms = 0;
    uint64_t rng = 0x9E3779B97F4A7C15ULL;
  };
  std::size_t capacity_;
  std::size_t max_stages_;
  std::vector<Stage> stages_;  // reserved to max_stages_
  std::vector<std::string> counter_names_;
  std::unique_ptr<std::atomic<uint64_t>[]> counters_;
  std::size_t num_counters_ = 0;
  std::size_t max_counters_;
  mutable std::unique_ptr<double[]> scratch_;
};

// Records the time from construction to destruction (std::chrono::steady_clock) into a stage.
class ScopedStageTimer {
 public:
  ScopedStageTimer(StageStats& stats, int stage) : stats_(stats), stage_(stage), start_(std::chrono::steady_clock::now()) {}
  ~ScopedStageTimer() { stop(); }
  ScopedStageTimer(const ScopedStageTimer&) = delete;
  ScopedStageTimer& operator=(const ScopedStageTimer&) = delete;
  // Records now instead of at destruction (once).
  void stop() {
    if (stage_ < 0) return;
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start_);
    stats_.record_ns(stage_, ns.count());
    stage_ = -1;
  }
  // Drops the measurement.
  void cancel() { stage_ = -1; }

 private:
  StageStats& stats_;
  int stage_;
  std::chrono::steady_clock::time_point start_;
};

// Linear-interpolation percentile (q in [0, 1]) of `n` values, partially reordering them in place.
double percentile_inplace(double* values, std::size_t n, double q);

}  // namespace ef
