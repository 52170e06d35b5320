#include "core/thread_pool.h"

#include <chrono>
#include <climits>
#include <cstdio>
#include <sstream>
#include <system_error>
#include <utility>

#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif

namespace ef {
namespace {

constexpr int kMaxThreads = 64;
constexpr int kMaxSpinUs = 10000;  // beyond 10 ms a spin is a busy wait, not a latency trick
#if defined(__linux__)
constexpr int kMaxCore = CPU_SETSIZE;  // the fixed cpu_set_t of pthread_setaffinity_np
#else
constexpr int kMaxCore = 1024;
#endif

// Tells the core we are in a spin loop: it yields pipeline resources to a sibling hyper-thread and
// saves power, without giving up the time slice.
inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
  asm volatile("yield" ::: "memory");
#endif
}

// Polls ready() for up to spin_ns nanoseconds; true as soon as it holds. Every 64 polls it reads
// the clock (dearer than a poll: a system call under qemu-user) and yields the core: when the
// thread it waits for shares this core (more runnable threads than cores, as when the pipeline
// stages run beside the pool), a pure spin would keep that thread off the core for the whole spin.
template <class Ready>
bool spin_until(int64_t spin_ns, Ready ready) {
  if (spin_ns <= 0) return false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(spin_ns);
  for (int i = 1;; ++i) {
    if (ready()) return true;
    cpu_relax();
    if ((i & 63) == 0) {
      if (std::chrono::steady_clock::now() >= deadline) return ready();
      std::this_thread::yield();
    }
  }
}

}  // namespace

Status ThreadPoolOptions::validate() const {
  if (threads < 1 || threads > kMaxThreads) {
    return error(ErrorCode::kInvalidArgument, "ThreadPoolOptions.threads = " + std::to_string(threads) +
                                                  ": must be in [1, " + std::to_string(kMaxThreads) +
                                                  "] (the calling thread included)");
  }
  if (spin_us < 0 || spin_us > kMaxSpinUs) {
    return error(ErrorCode::kInvalidArgument, "ThreadPoolOptions.spin_us = " + std::to_string(spin_us) +
                                                  ": must be in [0, " + std::to_string(kMaxSpinUs) + "] microseconds");
  }
  if (!cpu_affinity.empty() && static_cast<int>(cpu_affinity.size()) != threads - 1) {
    return error(ErrorCode::kInvalidArgument,
                 "ThreadPoolOptions.cpu_affinity has " + std::to_string(cpu_affinity.size()) + " cores for " +
                     std::to_string(threads - 1) + " workers (threads = " + std::to_string(threads) +
                     "): give one core per worker, or none");
  }
  for (std::size_t k = 0; k < cpu_affinity.size(); ++k) {
    if (cpu_affinity[k] < 0 || cpu_affinity[k] >= kMaxCore) {
      return error(ErrorCode::kInvalidArgument, "ThreadPoolOptions.cpu_affinity[" + std::to_string(k) + "] = " +
                                                    std::to_string(cpu_affinity[k]) + ": not a core id in [0, " +
                                                    std::to_string(kMaxCore) + ")");
    }
  }
  return Status::success();
}

std::string ThreadPoolOptions::describe() const {
  std::ostringstream s;
  s << "threads " << threads << "  # the calling thread included\n";
  s << "cpu_affinity [";
  for (std::size_t k = 0; k < cpu_affinity.size(); ++k) s << (k ? ", " : "") << cpu_affinity[k];
  s << "]  # core of each worker; empty = not pinned\n";
  s << "spin_us " << spin_us << " us  # polling before a waiting thread sleeps\n";
  return s.str();
}

ThreadPool::ThreadPool(const ThreadPoolOptions& options) : spin_ns_(int64_t{options.spin_us} * 1000) {}

Result<std::unique_ptr<ThreadPool>> ThreadPool::create(const ThreadPoolOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
#if !defined(__linux__)
  if (!options.cpu_affinity.empty())
    return error(ErrorCode::kUnsupported, "ThreadPoolOptions.cpu_affinity: pinning threads needs Linux");
#endif
  std::unique_ptr<ThreadPool> pool(new ThreadPool(options));
  pool->workers_.reserve(static_cast<std::size_t>(options.threads - 1));
  // On any error below, returning destroys `pool`, whose destructor stops and joins the workers
  // started so far.
  for (int k = 1; k < options.threads; ++k) {
    try {
      pool->workers_.emplace_back(&ThreadPool::worker_main, pool.get(), k);
    } catch (const std::system_error& e) {  // start-up only: std::thread reports failure by throwing
      return error(ErrorCode::kResourceExhausted,
                   "ThreadPool: cannot start worker " + std::to_string(k) + " of " +
                       std::to_string(options.threads - 1) + ": " + e.what());
    }
#if defined(__linux__)
    const pthread_t handle = pool->workers_.back().native_handle();
    // Named for top, perf and gdb. Linux allows 15 characters: "ef-pool-63" is 10; the buffer is
    // larger only so that the compiler can see any int fits.
    char name[24];
    std::snprintf(name, sizeof name, "ef-pool-%d", k);
    pthread_setname_np(handle, name);  // cosmetic: a failure changes nothing
    if (!options.cpu_affinity.empty()) {
      const int core = options.cpu_affinity[static_cast<std::size_t>(k - 1)];
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(core, &set);
      if (const int rc = pthread_setaffinity_np(handle, sizeof set, &set); rc != 0) {
        return error(ErrorCode::kInvalidArgument,
                     "ThreadPool: cannot pin worker " + std::to_string(k) + " (cpu_affinity[" + std::to_string(k - 1) +
                         "]) to core " + std::to_string(core) + ": " + std::system_category().message(rc) +
                         " (is the core online and in this process's allowed set?)");
      }
    }
#endif
  }
  return Result<std::unique_ptr<ThreadPool>>(std::move(pool));
}

ThreadPool::~ThreadPool() { stop_workers(); }

void ThreadPool::stop_workers() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true, std::memory_order_release);
  }
  work_cv_.notify_all();
  for (std::thread& w : workers_) {
    if (w.joinable()) w.join();
  }
}

void ThreadPool::parallel_for(int task_count, ThreadPoolTask fn, void* context) noexcept {
  // Every thread makes at most one fetch_add past the last task: keep next_task_ from overflowing.
  assert(task_count <= INT_MAX - kMaxThreads);
  if (task_count <= 0) return;
  if (workers_.empty()) {
    // One thread: a plain loop, no lock. Nothing is shared, so concurrent calls are harmless.
    for (int t = 0; t < task_count; ++t) fn(context, t, 0);
    return;
  }
  std::lock_guard<std::mutex> call(call_mutex_);
  if (task_count == 1) {  // waking the workers would cost more than the task
    fn(context, 0, 0);
    return;
  }
  // Publish the call. The plain fields are safe to rewrite: every worker has reported back from the
  // previous call (remaining_ == 0) and reads them only after it sees the new generation.
  fn_ = fn;
  context_ = context;
  task_count_ = task_count;
  next_task_.store(0, std::memory_order_relaxed);
  remaining_.store(static_cast<int>(workers_.size()), std::memory_order_relaxed);
  bool wake = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    generation_.store(generation_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
    wake = sleeping_ > 0;  // workers still spinning see the new generation without a system call
  }
  if (wake) work_cv_.notify_all();

  run_tasks(0);  // the caller works too, as thread 0
  wait_for_workers();
}

void ThreadPool::run_tasks(int thread_index) {
  const ThreadPoolTask fn = fn_;
  void* const context = context_;
  const int n = task_count_;
  for (int t = next_task_.fetch_add(1, std::memory_order_relaxed); t < n;
       t = next_task_.fetch_add(1, std::memory_order_relaxed)) {
    fn(context, t, thread_index);
  }
}

void ThreadPool::wait_for_workers() {
  // Acquire pairs with each worker's release decrement: their tasks' writes are now visible here.
  const auto done = [this] { return remaining_.load(std::memory_order_acquire) == 0; };
  if (spin_until(spin_ns_, done)) return;
  std::unique_lock<std::mutex> lock(mutex_);
  while (!done()) {
    caller_sleeping_ = true;
    done_cv_.wait(lock);
  }
  caller_sleeping_ = false;
}

int64_t ThreadPool::wait_for_work(int64_t seen) {
  // A published call wins over stop: its caller is waiting for every worker to report back.
  int64_t g = seen;
  const auto ready = [&] {
    g = generation_.load(std::memory_order_acquire);
    return g != seen || stop_.load(std::memory_order_acquire);
  };
  if (!spin_until(spin_ns_, ready)) {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!ready()) {
      ++sleeping_;
      work_cv_.wait(lock);
      --sleeping_;
    }
  }
  return g != seen ? g : -1;
}

void ThreadPool::worker_main(int thread_index) noexcept {
  int64_t seen = 0;
  for (;;) {
    const int64_t g = wait_for_work(seen);
    if (g < 0) return;
    seen = g;
    run_tasks(thread_index);
    // Release: this worker's task writes (and its last reads of fn_, context_, task_count_) happen
    // before the caller, or the next call, sees remaining_ == 0.
    if (remaining_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      // Under the lock, so that a caller that has just found remaining_ != 0 is already waiting.
      std::lock_guard<std::mutex> lock(mutex_);
      if (caller_sleeping_) done_cv_.notify_one();
    }
  }
}

}  // namespace ef
