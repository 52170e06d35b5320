// ThreadPool runs every task exactly once across the workers and the caller, allocates nothing per
// call, and shuts down cleanly; split_rows covers a range exactly. Also run under ThreadSanitizer
// (.ci/run phase 3): tasks write plain ints, so a missing happens-before edge is reported there.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif

#include "support/alloc_counter.h"
#include "core/thread_pool.h"

namespace ef {
namespace {

std::unique_ptr<ThreadPool> make_pool(int threads, int spin_us = ThreadPoolOptions{}.spin_us) {
  ThreadPoolOptions options;
  options.threads = threads;
  options.spin_us = spin_us;
  auto pool = ThreadPool::create(options);
  EXPECT_TRUE(pool.ok()) << (pool.ok() ? "" : to_string(pool.error()));
  return pool.ok() ? std::move(pool).value() : nullptr;
}

// Per-task run counts (plain ints: each task writes only its own slot) and the thread that ran it.
struct CountTasks {
  std::vector<int> runs;
  std::vector<int> thread_of;
  std::atomic<int> bad_thread_index{0};
  int threads = 1;

  static void run(void* context, int task, int thread_index) {
    auto* c = static_cast<CountTasks*>(context);
    ++c->runs[static_cast<std::size_t>(task)];
    c->thread_of[static_cast<std::size_t>(task)] = thread_index;
    if (thread_index < 0 || thread_index >= c->threads) c->bad_thread_index.fetch_add(1, std::memory_order_relaxed);
  }
};

// Tasks that each wait until all `n` have started: n tasks can then only finish if n distinct
// threads run them, one each, which proves that every thread (the caller too) takes part.
struct Barrier {
  int n = 0;
  std::atomic<int> arrived{0};
  std::atomic<bool> timed_out{false};
  std::vector<std::thread::id> thread_id;  // by thread_index
  std::vector<int> tasks_of;               // by thread_index

  void arrive_and_wait() {
    arrived.fetch_add(1, std::memory_order_acq_rel);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (arrived.load(std::memory_order_acquire) < n) {
      if (std::chrono::steady_clock::now() > deadline) {
        timed_out = true;
        return;
      }
      std::this_thread::yield();
    }
  }
  static void run(void* context, int task, int thread_index) {
    auto* b = static_cast<Barrier*>(context);
    b->thread_id[static_cast<std::size_t>(thread_index)] = std::this_thread::get_id();
    ++b->tasks_of[static_cast<std::size_t>(thread_index)];
    b->arrive_and_wait();
  }
};

TEST(ThreadPool, EveryTaskRunsExactlyOnce) {
  for (int threads : {1, 2, 4}) {
    auto pool = make_pool(threads);
    ASSERT_NE(pool, nullptr);
    EXPECT_EQ(pool->threads(), threads);
    for (int tasks : {0, 1, threads - 1, threads, 1000}) {
      SCOPED_TRACE("threads " + std::to_string(threads) + ", tasks " + std::to_string(tasks));
      CountTasks c;
      c.threads = threads;
      c.runs.assign(static_cast<std::size_t>(tasks), 0);
      c.thread_of.assign(static_cast<std::size_t>(tasks), -1);
      pool->parallel_for(tasks, &CountTasks::run, &c);
      for (int t = 0; t < tasks; ++t) ASSERT_EQ(c.runs[static_cast<std::size_t>(t)], 1) << "task " << t;
      EXPECT_EQ(c.bad_thread_index.load(), 0);
    }
  }
}

TEST(ThreadPool, OneThreadRunsEverythingOnTheCaller) {
  auto pool = make_pool(1);
  ASSERT_NE(pool, nullptr);
  std::vector<std::thread::id> ids(100);
  std::vector<int> index(100, -1);
  auto body = [&](int task, int thread_index) {
    ids[static_cast<std::size_t>(task)] = std::this_thread::get_id();
    index[static_cast<std::size_t>(task)] = thread_index;
  };
  pool->parallel_for(100, body);
  for (int t = 0; t < 100; ++t) {
    EXPECT_EQ(ids[static_cast<std::size_t>(t)], std::this_thread::get_id()) << "task " << t;
    EXPECT_EQ(index[static_cast<std::size_t>(t)], 0) << "task " << t;
  }
}

TEST(ThreadPool, CallerAndEveryWorkerTakePart) {
  for (int threads : {2, 4}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    auto pool = make_pool(threads);
    ASSERT_NE(pool, nullptr);
    for (int round = 0; round < 3; ++round) {  // the second and third calls find the workers spinning or asleep
      Barrier b;
      b.n = threads;
      b.thread_id.assign(static_cast<std::size_t>(threads), std::thread::id());
      b.tasks_of.assign(static_cast<std::size_t>(threads), 0);
      pool->parallel_for(threads, &Barrier::run, &b);
      ASSERT_FALSE(b.timed_out) << "not every thread took a task";
      EXPECT_EQ(b.thread_id[0], std::this_thread::get_id()) << "thread_index 0 is the caller";
      std::set<std::thread::id> distinct(b.thread_id.begin(), b.thread_id.end());
      EXPECT_EQ(distinct.size(), static_cast<std::size_t>(threads));
      for (int i = 0; i < threads; ++i) EXPECT_EQ(b.tasks_of[static_cast<std::size_t>(i)], 1) << "thread " << i;
      std::this_thread::sleep_for(std::chrono::milliseconds(round * 2));
    }
  }
}

TEST(ThreadPool, ManySmallCallsInARow) {
  constexpr int kCalls = 10000;  // about 1 s for all four pools, natively, under TSan and under qemu
  for (int threads : {2, 4}) {
    for (int spin_us : {0, 50}) {  // 0: every wait sleeps on the condition variable
      SCOPED_TRACE("threads " + std::to_string(threads) + ", spin_us " + std::to_string(spin_us));
      auto pool = make_pool(threads, spin_us);
      ASSERT_NE(pool, nullptr);
      // Plain ints: task t runs on different threads in different calls, so this also checks that
      // one call's writes happen before the next call's tasks.
      std::vector<int> sums(static_cast<std::size_t>(threads), 0);
      auto body = [&](int task, int) { ++sums[static_cast<std::size_t>(task)]; };
      for (int call = 0; call < kCalls; ++call) pool->parallel_for(threads, body);
      for (int t = 0; t < threads; ++t) EXPECT_EQ(sums[static_cast<std::size_t>(t)], kCalls) << "task " << t;
    }
  }
}

TEST(ThreadPool, ConcurrentCallersAreSerialised) {
  auto pool = make_pool(3);
  ASSERT_NE(pool, nullptr);
  constexpr int kCalls = 300;
  constexpr int kTasks = 8;
  // Per-thread_index scratch, as the executor keeps: a plain int per thread that would race (TSan)
  // if two calls ran on the pool at once.
  std::vector<int> scratch(3, 0);
  auto caller = [&](std::vector<int>* runs) {
    auto body = [&](int task, int thread_index) {
      ++scratch[static_cast<std::size_t>(thread_index)];
      ++(*runs)[static_cast<std::size_t>(task)];
    };
    for (int i = 0; i < kCalls; ++i) pool->parallel_for(kTasks, body);
  };
  std::vector<int> runs_a(kTasks, 0), runs_b(kTasks, 0);
  std::thread a(caller, &runs_a), b(caller, &runs_b);
  a.join();
  b.join();
  for (int t = 0; t < kTasks; ++t) {
    EXPECT_EQ(runs_a[static_cast<std::size_t>(t)], kCalls);
    EXPECT_EQ(runs_b[static_cast<std::size_t>(t)], kCalls);
  }
  EXPECT_EQ(scratch[0] + scratch[1] + scratch[2], 2 * kCalls * kTasks);
}

TEST(ThreadPool, DestructorReturnsWithIdleWorkers) {
  for (int threads : {2, 4}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    { auto never_used = make_pool(threads); }
    {
      auto asleep = make_pool(threads);  // workers spin 50 us, then sleep on the condition variable
      std::vector<int> runs(16, 0);
      auto body = [&](int task, int) { ++runs[static_cast<std::size_t>(task)]; };
      asleep->parallel_for(16, body);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    {
      auto spinning = make_pool(threads, 10000);  // destroyed while the workers still poll
      std::vector<int> runs(16, 0);
      auto body = [&](int task, int) { ++runs[static_cast<std::size_t>(task)]; };
      spinning->parallel_for(16, body);
    }
  }
}

TEST(ThreadPool, NoHeapAllocationPerCall) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  for (int threads : {1, 2, 4}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    auto pool = make_pool(threads);
    ASSERT_NE(pool, nullptr);
    CountTasks c;
    c.threads = threads;
    c.runs.assign(64, 0);
    c.thread_of.assign(64, -1);
    pool->parallel_for(64, &CountTasks::run, &c);  // warm-up: first wake of every worker
    auto body = [&c](int task, int thread_index) { CountTasks::run(&c, task, thread_index); };
    test::AllocationCounter count;  // global: the workers' allocations count too
    for (int call = 0; call < 200; ++call) {
      pool->parallel_for(64, &CountTasks::run, &c);
      pool->parallel_for(7, body);
      pool->parallel_for(1, body);
    }
    EXPECT_EQ(count.global_allocations(), 0u);
    EXPECT_EQ(count.thread_allocations(), 0u);
  }
}

TEST(ThreadPool, CreateRejectsBadOptionsNamingTheValue) {
  for (int threads : {0, 65, -3}) {
    ThreadPoolOptions options;
    options.threads = threads;
    auto pool = ThreadPool::create(options);
    ASSERT_FALSE(pool.ok()) << threads;
    EXPECT_EQ(pool.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(pool.error().message.find("threads = " + std::to_string(threads)), std::string::npos)
        << pool.error().message;
  }
  for (int threads : {1, 64}) {
    ThreadPoolOptions options;
    options.threads = threads;
    options.spin_us = 0;
    auto pool = ThreadPool::create(options);
    EXPECT_TRUE(pool.ok()) << threads;
  }
  ThreadPoolOptions options;
  options.threads = 3;
  options.cpu_affinity = {0};  // one core for two workers
  auto pool = ThreadPool::create(options);
  ASSERT_FALSE(pool.ok());
  EXPECT_NE(pool.error().message.find("cpu_affinity has 1 cores for 2 workers"), std::string::npos)
      << pool.error().message;
  options.cpu_affinity = {0, -1};
  pool = ThreadPool::create(options);
  ASSERT_FALSE(pool.ok());
  EXPECT_NE(pool.error().message.find("cpu_affinity[1] = -1"), std::string::npos) << pool.error().message;
  options.cpu_affinity.clear();
  options.spin_us = -1;
  pool = ThreadPool::create(options);
  ASSERT_FALSE(pool.ok());
  EXPECT_NE(pool.error().message.find("spin_us = -1"), std::string::npos) << pool.error().message;
}

TEST(ThreadPool, DescribeNamesEveryField) {
  ThreadPoolOptions options;
  options.threads = 3;
  options.cpu_affinity = {2, 5};
  const std::string d = options.describe();
  EXPECT_NE(d.find("threads 3"), std::string::npos) << d;
  EXPECT_NE(d.find("cpu_affinity [2, 5]"), std::string::npos) << d;
  EXPECT_NE(d.find("spin_us 50 us"), std::string::npos) << d;
}

#if defined(__linux__)
TEST(ThreadPool, PinsWorkersToTheGivenCores) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  int core = -1;
  for (int c = 0; c < CPU_SETSIZE && core < 0; ++c) {
    if (CPU_ISSET(c, &allowed)) core = c;
  }
  ASSERT_GE(core, 0);
  ThreadPoolOptions options;
  options.threads = 2;
  options.cpu_affinity = {core};
  auto pool = ThreadPool::create(options);
  ASSERT_TRUE(pool.ok()) << to_string(pool.error());

  // Two barrier tasks: the worker must run one of them, and reports its own affinity mask.
  struct Probe {
    Barrier barrier;
    int worker_cores = -1;   // cores in the worker's mask
    bool worker_on_core = false;
  } probe;
  probe.barrier.n = 2;
  probe.barrier.thread_id.assign(2, std::thread::id());
  probe.barrier.tasks_of.assign(2, 0);
  const int expected_core = core;
  auto body = [&](int task, int thread_index) {
    if (thread_index == 1) {
      cpu_set_t mine;
      CPU_ZERO(&mine);
      if (pthread_getaffinity_np(pthread_self(), sizeof mine, &mine) == 0) {
        probe.worker_cores = CPU_COUNT(&mine);
        probe.worker_on_core = CPU_ISSET(expected_core, &mine);
      }
    }
    Barrier::run(&probe.barrier, task, thread_index);
  };
  (*pool)->parallel_for(2, body);
  ASSERT_FALSE(probe.barrier.timed_out);
  EXPECT_EQ(probe.worker_cores, 1);
  EXPECT_TRUE(probe.worker_on_core) << "core " << core;

  // A core id the cpu_set_t can hold but (almost surely) no machine here has: the OS refuses it.
  const int absent = CPU_SETSIZE - 1;
  if (CPU_ISSET(absent, &allowed)) GTEST_SKIP() << "this machine has core " << absent;
  options.cpu_affinity = {absent};
  auto refused = ThreadPool::create(options);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("core " + std::to_string(absent)), std::string::npos)
      << refused.error().message;
}
#endif

TEST(SplitRows, CoversEveryRowOnceWithBalancedSizes) {
  for (int rows : {0, 1, 2, 3, 5, 7, 64, 100, 1001}) {
    for (int tasks : {1, 2, 3, 4, 5, 8, 13, 64}) {
      SCOPED_TRACE("rows " + std::to_string(rows) + ", tasks " + std::to_string(tasks));
      int expected_begin = 0;
      for (int t = 0; t < tasks; ++t) {
        int begin = -1, end = -1;
        split_rows(rows, tasks, t, &begin, &end);
        ASSERT_EQ(begin, expected_begin) << "task " << t;
        const int size = end - begin;
        // The first rows % tasks ranges are one row longer; when rows < tasks the rest are empty.
        ASSERT_EQ(size, rows / tasks + (t < rows % tasks ? 1 : 0)) << "task " << t;
        expected_begin = end;
      }
      EXPECT_EQ(expected_begin, rows);
    }
  }
}

TEST(SplitRows, SplitsAConvolutionAcrossThePool) {
  // The executor's use: tasks = rows split into blocks, each task writes its own rows.
  auto pool = make_pool(4);
  ASSERT_NE(pool, nullptr);
  constexpr int kRows = 37;
  constexpr int kTasks = 8;
  std::vector<int> row_written(kRows, 0);
  auto body = [&](int task, int) {
    int begin = 0, end = 0;
    split_rows(kRows, kTasks, task, &begin, &end);
    for (int y = begin; y < end; ++y) ++row_written[static_cast<std::size_t>(y)];
  };
  pool->parallel_for(kTasks, body);
  // A temporary lambda works too: it lives until the call returns.
  pool->parallel_for(kTasks, [&](int task, int) {
    int begin = 0, end = 0;
    split_rows(kRows, kTasks, task, &begin, &end);
    for (int y = begin; y < end; ++y) --row_written[static_cast<std::size_t>(y)];
  });
  for (int y = 0; y < kRows; ++y) EXPECT_EQ(row_written[static_cast<std::size_t>(y)], 0) << "row " << y;
  pool->parallel_for(kTasks, body);
  for (int y = 0; y < kRows; ++y) EXPECT_EQ(row_written[static_cast<std::size_t>(y)], 1) << "row " << y;
}

}  // namespace
}  // namespace ef
