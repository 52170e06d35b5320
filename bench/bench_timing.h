// Timing of the nn benchmarks: thread CPU time, batches sized by doubling, median and spread.
#pragma once

#include <time.h>

#include <algorithm>
#include <vector>

namespace ef::bench {

// Seconds of CPU time this thread has used: timings exclude the time other processes hold the core
// (the same as wall time on an idle, pinned core; far steadier on a shared one).
inline double thread_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + double(ts.tv_nsec) * 1e-9;
}

struct Timing {
  double median = 0;  // seconds per call: the figure reported
  double best = 0;    // the fastest run (the peaks: nothing makes a loop faster than the hardware)
  double iqr = 0;     // interquartile range / median: the noise of the figure
};

// Seconds per call of `fn`: `reps` (>= 1) runs of one batch of calls each, the batch sized (by
// doubling, which is also the warm-up) to take at least `min_ms` milliseconds.
template <class F>
Timing time_calls(F&& fn, int reps, double min_ms) {
  long calls = 1;
  for (;;) {
    const double t0 = thread_cpu_seconds();
    for (long i = 0; i < calls; ++i) fn();
    if ((thread_cpu_seconds() - t0) * 1e3 >= min_ms || calls >= (1L << 40)) break;
    calls *= 2;
  }
  std::vector<double> per_call;
  for (int r = 0; r < std::max(reps, 1); ++r) {
    const double t0 = thread_cpu_seconds();
    for (long i = 0; i < calls; ++i) fn();
    per_call.push_back((thread_cpu_seconds() - t0) / double(calls));
  }
  std::sort(per_call.begin(), per_call.end());
  Timing t;
  t.median = per_call[per_call.size() / 2];
  t.best = per_call.front();
  t.iqr = (per_call[per_call.size() * 3 / 4] - per_call[per_call.size() / 4]) / t.median;
  return t;
}

}  // namespace ef::bench
