// StageRing (core/stage_ring.h): slots pass every stage in order, one stage at a time per slot, the
// first stage is never more than `capacity` slots ahead of the last, and close() releases waiters.
// In test_core so that it runs under ThreadSanitizer in CI.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <random>
#include <thread>
#include <vector>

#include "core/stage_ring.h"

namespace ef {
namespace {

using std::chrono::milliseconds;

struct Item {
  int64_t value = -1;       // written by stage 0
  int64_t stage_seen = -1;  // the last stage that touched the slot
  std::atomic<int> holders{0};
};

TEST(StageRing, ThreeStagesOnThreeThreadsKeepOrderAndNeverShareASlot) {
  constexpr int kItems = 3000, kStages = 3;
  StageRing<Item> ring(3, kStages, [](Item&) {});
  std::atomic<int64_t> ahead_max{0};
  std::atomic<bool> bad{false};
  auto stage = [&](int s) {
    std::mt19937 rng(static_cast<unsigned>(s + 1));
    for (int64_t n = 0; n < kItems; ++n) {
      Item* it = ring.acquire(s, std::chrono::seconds(10));
      if (it == nullptr) {
        bad = true;
        return;
      }
      if (it->holders.fetch_add(1) != 0) bad = true;  // another stage holds it too
      if (s == 0) {
        it->value = n;
        const int64_t ahead = ring.released(0) - ring.released(kStages - 1);
        if (ahead > ahead_max) ahead_max = ahead;
      } else if (it->value != n || it->stage_seen != s - 1) {
        bad = true;  // out of order, or a stage skipped
      }
      it->stage_seen = s;
      if (rng() % 8 == 0) std::this_thread::sleep_for(std::chrono::microseconds(rng() % 200));
      it->holders.fetch_sub(1);
      ring.release(s);
    }
  };
  std::thread t0(stage, 0), t1(stage, 1);
  stage(2);
  t0.join();
  t1.join();
  EXPECT_FALSE(bad);
  EXPECT_LE(ahead_max.load(), 3);  // never more slots in flight than the ring has
  for (int s = 0; s < kStages; ++s) EXPECT_EQ(ring.released(s), kItems);
}

TEST(StageRing, OneSlotSerialisesTheStagesOnOneThread) {
  StageRing<int> ring(1, 3, [](int& v) { v = 0; });
  for (int n = 0; n < 5; ++n) {
    int* a = ring.acquire(0, milliseconds(0));
    ASSERT_NE(a, nullptr);
    EXPECT_EQ(ring.acquire(0, milliseconds(0)), a);  // the same slot until released
    EXPECT_EQ(ring.acquire(1, milliseconds(0)), nullptr);  // stage 1 waits for stage 0
    ring.release(0);
    EXPECT_EQ(ring.acquire(0, milliseconds(0)), nullptr);  // the only slot is in flight
    ASSERT_EQ(ring.acquire(1, milliseconds(0)), a);
    ring.release(1);
    ASSERT_EQ(ring.acquire(2, milliseconds(0)), a);
    ring.release(2);
  }
}

TEST(StageRing, CloseWakesAWaitingStage) {
  StageRing<int> ring(2, 2, [](int&) {});
  std::atomic<bool> woke{false};
  std::thread waiter([&] {
    // Stage 1 has nothing to take until stage 0 releases: this waits until close().
    woke = ring.acquire(1, std::chrono::seconds(30)) == nullptr;
  });
  std::this_thread::sleep_for(milliseconds(50));
  const auto t0 = std::chrono::steady_clock::now();
  ring.close();
  waiter.join();
  EXPECT_TRUE(woke);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  EXPECT_EQ(ring.acquire(0, milliseconds(0)), nullptr);
}

}  // namespace
}  // namespace ef
