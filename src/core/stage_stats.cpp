#include "core/stage_stats.h"

#include <algorithm>
#include <cmath>

namespace ef {

double percentile_inplace(double* v, std::size_t n, double q) {
  if (n == 0) return 0;
  q = std::clamp(q, 0.0, 1.0);
  const double pos = q * static_cast<double>(n - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const double frac = pos - static_cast<double>(lo);
  std::nth_element(v, v + lo, v + n);
  const double a = v[lo];
  if (frac == 0 || lo + 1 >= n) return a;
  // The next order statistic is the minimum of the part above lo.
  const double b = *std::min_element(v + lo + 1, v + n);
  return a + frac * (b - a);
}

StageStats::StageStats(std::size_t capacity, std::size_t max_stages, std::size_t max_counters)
    : capacity_(std::max<std::size_t>(capacity, 1)),
      max_stages_(max_stages),
      counters_(new std::atomic<uint64_t>[max_counters]),
      max_counters_(max_counters),
      scratch_(new double[std::max<std::size_t>(capacity, 1)]) {
  stages_.reserve(max_stages_);
  counter_names_.reserve(max_counters_);
  for (std::size_t i = 0; i < max_counters_; ++i) counters_[i].store(0, std::memory_order_relaxed);
}

int StageStats::add_stage(std::string_view name) {
  if (int id = stage_id(name); id >= 0) return id;
  if (stages_.size() >= max_stages_) return -1;
  Stage s;
  s.name = std::string(name);
  s.samples.reset(new double[capacity_]);
  s.rng ^= static_cast<uint64_t>(stages_.size() + 1) * 0xBF58476D1CE4E5B9ULL;
  stages_.push_back(std::move(s));
  return static_cast<int>(stages_.size() - 1);
}

int StageStats::add_counter(std::string_view name) {
  if (int id = counter_id(name); id >= 0) return id;
  if (num_counters_ >= max_counters_) return -1;
  counter_names_.emplace_back(name);
  return static_cast<int>(num_counters_++);
}

int StageStats::stage_id(std::string_view name) const {
  for (std::size_t i = 0; i < stages_.size(); ++i)
    if (stages_[i].name == name) return static_cast<int>(i);
  return -1;
}

int StageStats::counter_id(std::string_view name) const {
  for (std::size_t i = 0; i < num_counters_; ++i)
    if (counter_names_[i] == name) return static_cast<int>(i);
  return -1;
}

void StageStats::record_ns(int stage, int64_t nanoseconds) { record_ms(stage, static_cast<double>(nanoseconds) * 1e-6); }

void StageStats::record_ms(int stage, double ms) {
  if (stage < 0 || static_cast<std::size_t>(stage) >= stages_.size()) return;
  Stage& s = stages_[stage];
  ++s.count;
  s.sum_ms += ms;
  if (s.count == 1 || ms > s.max_ms) s.max_ms = ms;
  if (s.kept < capacity_) {
    s.samples[s.kept++] = ms;
    return;
  }
  // Reservoir: keep the new sample with probability capacity / count.
  s.rng ^= s.rng << 13;
  s.rng ^= s.rng >> 7;
  s.rng ^= s.rng << 17;
  const uint64_t j = s.rng % s.count;
  if (j < capacity_) s.samples[j] = ms;
}

StageSummary StageStats::summary(int stage) const {
  StageSummary out;
  if (stage < 0 || static_cast<std::size_t>(stage) >= stages_.size()) return out;
  const Stage& s = stages_[stage];
  out.count = s.count;
  if (s.count == 0) return out;
  out.total_ms = s.sum_ms;
  out.mean_ms = s.sum_ms / static_cast<double>(s.count);
  out.max_ms = s.max_ms;
  std::copy(s.samples.get(), s.samples.get() + s.kept, scratch_.get());
  out.median_ms = percentile_inplace(scratch_.get(), s.kept, 0.5);
  out.p95_ms = percentile_inplace(scratch_.get(), s.kept, 0.95);
  return out;
}

void StageStats::reset() {
  for (Stage& s : stages_) {
    s.kept = 0;
    s.count = 0;
    s.sum_ms = 0;
    s.max_ms = 0;
  }
  for (std::size_t i = 0; i < max_counters_; ++i) counters_[i].store(0, std::memory_order_relaxed);
}

}  // namespace ef
