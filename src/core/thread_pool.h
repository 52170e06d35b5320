// A fixed pool of threads for splitting one piece of work (a layer, a block of rows) across cores.
//
// Sized once at start-up; parallel_for() then runs task 0..n-1 on the workers and on the calling
// thread, and returns when all tasks are done. The per-call path allocates nothing (a function
// pointer and a context pointer, tasks taken from an atomic counter) and throws nothing.
//
// The default is one thread: the pipeline already runs its stages in parallel, so a pool is only
// worth its wake-up cost for a stage that is the bottleneck on an otherwise idle core. With one
// thread parallel_for() is a plain loop on the caller: no workers, no locks, no atomics.
// Cost of an empty call with 2 threads (x86-64, 2 cores): about 0.5 us while the worker is still
// spinning from the previous call on its own core, 4-30 us when it has to be woken from sleep,
// about 6 us when both threads share one busy core. Split work into tasks of tens of microseconds.
//
// Threads: create() and the destructor from one owning thread. parallel_for() from any thread, one
// call at a time per pool: a pool with workers serialises concurrent calls with a mutex (the second
// waits for the first to finish); a one-thread pool takes no lock and has nothing shared, so
// concurrent calls on it simply run side by side, each on its own caller as thread_index 0.
// fn must not call parallel_for() on the same pool (it would deadlock). The pool must not be
// destroyed while a parallel_for() is running.
#pragma once

#include <atomic>
#include <cassert>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "core/result.h"

namespace ef {

struct ThreadPoolOptions {
  // Total threads that run tasks, the calling thread included, in [1, 64]; threads - 1 workers are
  // started by create(). Default 1: everything runs inline on the caller.
  int threads = 1;
  // Cores to pin the workers to, one per worker: cpu_affinity[k] is the core of the worker with
  // thread_index k + 1, so the size must be threads - 1. Empty (default) = no pinning. The calling
  // thread is never pinned here: its affinity belongs to whoever created it. Linux only.
  std::vector<int> cpu_affinity;
  // Microseconds a waiting thread (a worker between calls, the caller waiting for the workers)
  // polls (yielding the core now and then) before it sleeps on a condition variable, in
  // [0, 10000]. Back-to-back calls (the layers of a network) then skip the futex wake-up; longer
  // gaps cost at most this much busy CPU per thread. 0 = sleep at once.
  int spin_us = 50;

  // An error naming the first field out of range (the OS may still refuse a core: see create()).
  Status validate() const;
  // One line per field with its unit, for logs.
  std::string describe() const;
};

// One task: `context` is the pointer given to parallel_for, `task` in [0, task_count), and
// `thread_index` in [0, threads) says which thread runs it: 0 is the calling thread, k the k-th
// worker, always. Within one pool an index runs one task at a time (a one-thread pool called from
// several threads at once excepted, see above), so per-thread scratch may be indexed by it.
// Must not throw: an exception ends the program (std::terminate).
using ThreadPoolTask = void (*)(void* context, int task, int thread_index);

class ThreadPool {
 public:
  // Starts options.threads - 1 workers and pins them as asked. Errors: kInvalidArgument for a
  // thread count outside [1, 64], a cpu_affinity of the wrong size or a negative / too large core
  // id, or a spin_us outside [0, 10000]; kUnsupported for cpu_affinity off Linux; kResourceExhausted when a
  // thread cannot be started; kInvalidArgument naming the core when the OS refuses to pin to it.
  static Result<std::unique_ptr<ThreadPool>> create(const ThreadPoolOptions& options);

  // Stops and joins the workers (they are idle: no parallel_for may be running).
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  // Runs fn(context, task, thread_index) once for every task in [0, task_count) and returns when
  // all have finished; their writes are then visible to the caller. Tasks are handed out in
  // increasing order to whichever thread is free, so make them about equal in cost, or make more
  // tasks than threads. task_count <= 0 does nothing; task_count must be at most INT_MAX - 64.
  // One task runs inline on the caller. No heap allocation. noexcept: a task that throws ends the
  // program on the caller as on a worker, rather than leaving workers running after an unwind.
  void parallel_for(int task_count, ThreadPoolTask fn, void* context) noexcept;

  // The same for a callable `body(int task, int thread_index)`, borrowed for the call: a lambda
  // with captures, even a temporary one, is fine (nothing is copied, nothing allocated).
  template <class Body>
  void parallel_for(int task_count, Body&& body) noexcept {
    using B = std::remove_reference_t<Body>;
    parallel_for(
        task_count, [](void* c, int task, int thread_index) { (*static_cast<B*>(c))(task, thread_index); },
        const_cast<void*>(static_cast<const void*>(&body)));
  }

  // Total threads, the caller included (options.threads).
  int threads() const { return static_cast<int>(workers_.size()) + 1; }

 private:
  explicit ThreadPool(const ThreadPoolOptions& options);
  void worker_main(int thread_index) noexcept;
  // Waits until a generation other than `seen` is published (returns it) or the pool stops (-1).
  int64_t wait_for_work(int64_t seen);
  void wait_for_workers();
  void run_tasks(int thread_index);
  void stop_workers();

  std::vector<std::thread> workers_;
  const int64_t spin_ns_;

  // The current call, written by the caller before it publishes a new generation and read by the
  // workers after they see it; not rewritten until every worker has reported back (remaining_).
  ThreadPoolTask fn_ = nullptr;
  void* context_ = nullptr;
  int task_count_ = 0;
  std::atomic<int> next_task_{0};
  std::atomic<int> remaining_{0};  // workers that have not yet finished the current generation

  std::mutex call_mutex_;           // one parallel_for at a time
  std::mutex mutex_;                // guards sleeping_, caller_sleeping_ and changes of generation_ / stop_
  std::condition_variable work_cv_;  // workers: a new generation or stop
  std::condition_variable done_cv_;  // caller: remaining_ reached 0
  std::atomic<int64_t> generation_{0};  // calls published so far; atomic so that spinning workers can poll it
  std::atomic<bool> stop_{false};
  int sleeping_ = 0;              // workers blocked on work_cv_
  bool caller_sleeping_ = false;  // the caller is blocked on done_cv_
};

// Splits rows [0, rows) into `tasks` contiguous ranges of balanced size and returns the range of
// task `task` in [*begin, *end): the first rows % tasks ranges are one row longer. When rows < tasks
// the last ranges are empty (begin == end). Requires rows >= 0, tasks >= 1, 0 <= task < tasks.
inline void split_rows(int rows, int tasks, int task, int* begin, int* end) {
  assert(rows >= 0 && tasks >= 1 && task >= 0 && task < tasks);
  const int base = rows / tasks;
  const int extra = rows % tasks;
  *begin = task * base + (task < extra ? task : extra);
  *end = *begin + base + (task < extra ? 1 : 0);
}

}  // namespace ef
