// The steady-state frame path must not touch the heap: ring slots and arenas are sized once.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "support/alloc_counter.h"
#include "core/arena.h"
#include "core/frame.h"
#include "core/frame_ring.h"

namespace ef {
namespace {

// Keeps the compiler from eliding a new/delete pair or an unused allocation.
template <class T>
void escape(T* p) {
  asm volatile("" : : "g"(p) : "memory");
}

TEST(AllocationCounter, SeesAllocationsOfThisThread) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  test::AllocationCounter count;
  {
    int* p = new int(3);
    escape(p);
    delete p;
  }
  EXPECT_EQ(count.thread_allocations(), 1u);
  EXPECT_EQ(count.thread_deallocations(), 1u);
  EXPECT_GE(count.thread_bytes(), sizeof(int));
  {
    std::vector<double> v(100);
    escape(v.data());
    float* a = new (std::align_val_t(64)) float[16];  // the aligned array form, as Arena uses
    escape(a);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(a) % 64, 0u);
    ::operator delete[](a, std::align_val_t(64));
    std::string s(200, 'x');  // beyond any small-string buffer
    escape(s.data());
  }
  EXPECT_EQ(count.thread_allocations(), 4u);
  EXPECT_EQ(count.thread_deallocations(), 4u);
  EXPECT_GE(count.thread_bytes(), sizeof(int) + 100 * sizeof(double) + 16 * sizeof(float) + 200);
  EXPECT_EQ(count.global_allocations(), count.thread_allocations()) << "no other thread is running";
  count.restart();
  EXPECT_EQ(count.thread_allocations(), 0u);
}

TEST(AllocationCounter, OtherThreadsCountGloballyNotOnThisThread) {
  test::AllocationCounter count;
  std::thread t([] {
    for (int i = 0; i < 5; ++i) {
      auto p = std::make_unique<std::vector<int>>(10);
      escape(p.get());
    }
  });
  t.join();
  // std::thread itself allocates its state (once) on this thread; the ten allocations inside run
  // on the other thread.
  EXPECT_LE(count.thread_allocations(), 2u);
  EXPECT_GE(count.global_allocations(), count.thread_allocations() + 10u);
}

void fill_source(Frame& f, int64_t i) {
  f.index = i;
  f.timestamp = 0.033 * static_cast<double>(i);
  f.color.fill(Rgb8{static_cast<uint8_t>(i), 1, 2});
  f.depth.fill(1.5f + static_cast<float>(i));
  f.labels.fill(static_cast<uint8_t>(i % 14));
  f.has_labels = true;
  f.has_pose = true;
  f.T_wc = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * static_cast<double>(i), 0, 0));
  f.name = "frame-0000";  // within the reserved capacity
  f.name.back() = static_cast<char>('0' + i % 10);
}

TEST(ZeroAllocation, SteadyStateRingAndArenaDoNotTouchTheHeap) {
  constexpr int kW = 64, kH = 48;
  FrameRing<Frame> ring(3, [&](Frame& f) { f.allocate(kW, kH, true); });
  Frame source;
  source.allocate(kW, kH, true);
  Arena arena(1 << 16);
  uint64_t checksum = 0;

  auto one_frame = [&](int64_t i, bool read_it) {
    fill_source(source, i);
    Frame& w = ring.acquire_write();
    copy_frame(source, w);
    ring.commit();
    if (!read_it) return;  // overload: the next write drops the oldest ready frame
    const Frame* r = ring.acquire_read(std::chrono::microseconds(100));
    ASSERT_NE(r, nullptr);
    float* scratch = arena.allocate<float>(static_cast<std::size_t>(kW) * kH, 32);
    ASSERT_NE(scratch, nullptr);
    std::memcpy(scratch, r->depth.data(), sizeof(float) * kW * kH);
    uint8_t* tags = arena.allocate<uint8_t>(100);
    ASSERT_NE(tags, nullptr);
    checksum += static_cast<uint64_t>(scratch[kW * kH - 1]) + r->labels(1, 1) + r->color(0, 0).r + r->name.size();
    ring.release();
    arena.reset();
  };

  // Warm-up: the first pass through every code path (and gtest's own bookkeeping) may allocate.
  for (int i = 0; i < 10; ++i) one_frame(i, i % 3 != 0);
  ASSERT_FALSE(HasFatalFailure());

  test::AllocationCounter count;
  for (int i = 10; i < 500; ++i) one_frame(i, i % 3 != 0);
  const uint64_t thread_allocs = count.thread_allocations();
  const uint64_t global_allocs = count.global_allocations();
  const uint64_t thread_frees = count.thread_deallocations();

  EXPECT_EQ(thread_allocs, 0u);
  EXPECT_EQ(thread_frees, 0u);
  EXPECT_EQ(global_allocs, 0u);
  EXPECT_GT(ring.dropped(), 0u) << "the overload path was exercised too";
  EXPECT_EQ(arena.failures(), 0u);
  EXPECT_GT(checksum, 0u);
}

TEST(ZeroAllocation, CounterCatchesAnAllocatingCopy) {
  // The premise of the test above: a copy into a frame of another size does allocate, and the
  // counter sees it.
  Frame source;
  source.allocate(32, 24, true);
  source.has_labels = true;
  Frame small;
  small.allocate(16, 12, true);
  test::AllocationCounter count;
  copy_frame(source, small);
  EXPECT_GE(count.thread_allocations(), 3u);  // colour, depth, labels
  EXPECT_EQ(small.depth.width(), 32);
}

}  // namespace
}  // namespace ef
