// SurfelPool: every column (the 16 label bytes included) travels with a surfel through append,
// remove and remove_flagged; the full-pool policy evicts the oldest unstable surfels first, never
// stable or recently seen ones, and counts evictions and refusals; capacity validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "slam/surfel_pool.h"

namespace ef::slam {
namespace {

constexpr int kLabelBytes = SurfelPool::kLabelBytesPerSurfel;

SurfelPool make_sized_pool(int64_t capacity, int32_t evict_unseen_frames = 30) {
  SurfelPoolOptions o;
  o.capacity = capacity;
  o.evict_unseen_frames = evict_unseen_frames;
  auto p = SurfelPool::create(o);
  EXPECT_TRUE(p.ok()) << to_string(p.error());
  return std::move(p).value();
}

// A surfel whose every column is derived from `tag`, so that any mix-up of columns is visible.
struct Tagged {
  float x, y, z, nx, ny, nz, radius, confidence;
  uint32_t color;
  int32_t init_time, last_seen;
  uint8_t labels[kLabelBytes];
};

Tagged tagged(int tag) {
  Tagged t;
  const float f = static_cast<float>(tag);
  t.x = f + 0.1f;
  t.y = f + 0.2f;
  t.z = f + 0.3f;
  t.nx = f + 0.4f;
  t.ny = f + 0.5f;
  t.nz = f + 0.6f;
  t.radius = f + 0.7f;
  t.confidence = f + 0.8f;
  t.color = 0x10000u * static_cast<uint32_t>(tag) + 7u;
  t.init_time = 1000 + tag;
  t.last_seen = 2000 + tag;
  for (int k = 0; k < kLabelBytes; ++k) t.labels[k] = static_cast<uint8_t>(tag * 16 + k);
  return t;
}

int64_t append_tagged(SurfelPool& pool, int tag) {
  const Tagged t = tagged(tag);
  const int64_t id = pool.append(t.x, t.y, t.z, t.nx, t.ny, t.nz, t.radius, t.confidence, t.color, t.init_time);
  if (id >= 0) {
    pool.last_seen()[id] = t.last_seen;
    std::memcpy(pool.labels() + id * kLabelBytes, t.labels, kLabelBytes);
  }
  return id;
}

// Every column of surfel `id` equals tagged(tag).
void expect_tagged(const SurfelPool& pool, int64_t id, int tag) {
  const Tagged t = tagged(tag);
  EXPECT_EQ(pool.x()[id], t.x) << "id " << id << " tag " << tag;
  EXPECT_EQ(pool.y()[id], t.y) << "id " << id;
  EXPECT_EQ(pool.z()[id], t.z) << "id " << id;
  EXPECT_EQ(pool.nx()[id], t.nx) << "id " << id;
  EXPECT_EQ(pool.ny()[id], t.ny) << "id " << id;
  EXPECT_EQ(pool.nz()[id], t.nz) << "id " << id;
  EXPECT_EQ(pool.radius()[id], t.radius) << "id " << id;
  EXPECT_EQ(pool.confidence()[id], t.confidence) << "id " << id;
  EXPECT_EQ(pool.color()[id], t.color) << "id " << id;
  EXPECT_EQ(pool.init_time()[id], t.init_time) << "id " << id;
  EXPECT_EQ(pool.last_seen()[id], t.last_seen) << "id " << id;
  EXPECT_EQ(std::memcmp(pool.labels() + id * kLabelBytes, t.labels, kLabelBytes), 0) << "labels of id " << id;
}

TEST(SurfelPool, CapacityValidation) {
  SurfelPoolOptions o;
  EXPECT_TRUE(o.validate().ok());
  o.capacity = 0;
  EXPECT_FALSE(o.validate().ok());
  EXPECT_FALSE(SurfelPool::create(o).ok());
  o.capacity = -5;
  EXPECT_FALSE(SurfelPool::create(o).ok());
  o.capacity = 100'000'001;
  EXPECT_FALSE(SurfelPool::create(o).ok());
  o.capacity = 10;
  o.evict_unseen_frames = 0;
  EXPECT_FALSE(SurfelPool::create(o).ok());
  o.evict_unseen_frames = 1;
  auto one = SurfelPool::create(SurfelPoolOptions{1, 1});
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->capacity(), 1);
  EXPECT_EQ(one->size(), 0);
  EXPECT_GE(one->bytes(), SurfelPool::kBytesPerSurfel);
  EXPECT_EQ(SurfelPool::kBytesPerSurfel, 60u);
  SurfelPool big = make_sized_pool(100'000);
  EXPECT_GE(big.bytes(), 100'000 * SurfelPool::kBytesPerSurfel);
  // Columns padded to 64 bytes only, plus the block bounds (one per kBoundsBlock surfels).
  const std::size_t bounds = (100'000 + SurfelPool::kBoundsBlock - 1) / SurfelPool::kBoundsBlock *
                             sizeof(SurfelPool::BlockBounds);
  EXPECT_GE(big.bytes(), 100'000 * SurfelPool::kBytesPerSurfel + bounds);
  EXPECT_LT(big.bytes(), 100'000 * SurfelPool::kBytesPerSurfel + bounds + 12 * 64);
  EXPECT_NE(SurfelPoolOptions{}.describe().find("capacity"), std::string::npos);
  // Columns are 64-byte aligned.
  EXPECT_EQ(reinterpret_cast<uintptr_t>(big.x()) % 64, 0u);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(big.labels()) % 64, 0u);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(big.last_seen()) % 64, 0u);
}

TEST(SurfelPool, AppendWritesEveryColumnAndClearsLabels) {
  SurfelPool pool = make_sized_pool(4);
  // Dirty the label bytes of slot 0, then append: they must be cleared ("uniform").
  std::memset(pool.labels(), 0xAB, 4 * kLabelBytes);
  const int64_t id = pool.append(1, 2, 3, 0, 0, -1, 0.01f, 0.5f, pack_rgb(10, 20, 30), 42);
  ASSERT_EQ(id, 0);
  EXPECT_EQ(pool.size(), 1);
  EXPECT_EQ(pool.x()[0], 1.0f);
  EXPECT_EQ(pool.nz()[0], -1.0f);
  EXPECT_EQ(pool.radius()[0], 0.01f);
  EXPECT_EQ(pool.confidence()[0], 0.5f);
  EXPECT_EQ(unpack_r(pool.color()[0]), 10);
  EXPECT_EQ(unpack_g(pool.color()[0]), 20);
  EXPECT_EQ(unpack_b(pool.color()[0]), 30);
  EXPECT_EQ(pool.init_time()[0], 42);
  EXPECT_EQ(pool.last_seen()[0], 42);
  for (int k = 0; k < kLabelBytes; ++k) EXPECT_EQ(pool.labels()[k], 0) << k;
  EXPECT_EQ(pool.labels()[kLabelBytes], 0xAB);  // slot 1 untouched
  EXPECT_EQ(pool.counters().created, 1u);
}

TEST(SurfelPool, AppendOnFullPoolRefusesAndCounts) {
  SurfelPool pool = make_sized_pool(3);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(append_tagged(pool, i), i);
  EXPECT_TRUE(pool.full());
  EXPECT_EQ(append_tagged(pool, 9), -1);
  EXPECT_EQ(pool.size(), 3);
  EXPECT_EQ(pool.counters().refused, 1u);
  EXPECT_EQ(pool.counters().created, 3u);
  for (int i = 0; i < 3; ++i) expect_tagged(pool, i, i);
  pool.count_refused(5);
  EXPECT_EQ(pool.counters().refused, 6u);
}

TEST(SurfelPool, RemoveMovesTheLastSurfelWithAllColumns) {
  SurfelPool pool = make_sized_pool(10);
  for (int i = 0; i < 6; ++i) append_tagged(pool, i);
  pool.remove(1);  // surfel 5 moves into slot 1
  ASSERT_EQ(pool.size(), 5);
  expect_tagged(pool, 0, 0);
  expect_tagged(pool, 1, 5);
  expect_tagged(pool, 2, 2);
  expect_tagged(pool, 3, 3);
  expect_tagged(pool, 4, 4);
  pool.remove(4);  // the last: nothing moves
  ASSERT_EQ(pool.size(), 4);
  expect_tagged(pool, 1, 5);
  expect_tagged(pool, 3, 3);
  pool.remove(0);
  pool.remove(0);
  pool.remove(0);
  pool.remove(0);
  EXPECT_EQ(pool.size(), 0);
  EXPECT_EQ(pool.counters().removed, 6u);
  EXPECT_EQ(pool.counters().evicted, 0u);
  // Room again.
  EXPECT_EQ(append_tagged(pool, 7), 0);
  expect_tagged(pool, 0, 7);
}

TEST(SurfelPool, RemoveFlaggedKeepsOrderAndColumns) {
  SurfelPool pool = make_sized_pool(20);
  for (int i = 0; i < 12; ++i) append_tagged(pool, i);
  std::vector<uint8_t> flags(12, 0);
  for (int i : {0, 3, 4, 9, 11}) flags[i] = 1;
  EXPECT_EQ(pool.remove_flagged(flags.data()), 5);
  const int kept[] = {1, 2, 5, 6, 7, 8, 10};
  ASSERT_EQ(pool.size(), 7);
  for (int k = 0; k < 7; ++k) expect_tagged(pool, k, kept[k]);
  EXPECT_EQ(pool.counters().removed, 5u);
  // Nothing flagged: nothing changes; everything flagged: empty.
  std::vector<uint8_t> none(7, 0), all(7, 1);
  EXPECT_EQ(pool.remove_flagged(none.data()), 0);
  for (int k = 0; k < 7; ++k) expect_tagged(pool, k, kept[k]);
  EXPECT_EQ(pool.remove_flagged(all.data()), 7);
  EXPECT_EQ(pool.size(), 0);
}

TEST(SurfelPool, CopySurfelCopiesEveryColumn) {
  SurfelPool pool = make_sized_pool(4);
  append_tagged(pool, 1);
  append_tagged(pool, 2);
  pool.copy_surfel(1, 0);
  expect_tagged(pool, 0, 2);
  expect_tagged(pool, 1, 2);
}

TEST(SurfelPool, PermuteMovesEveryColumnAndKeepsCounters) {
  SurfelPool pool = make_sized_pool(12);
  for (int i = 0; i < 9; ++i) append_tagged(pool, i);
  const SurfelPoolCounters before = pool.counters();
  const int32_t old_of_new[9] = {4, 8, 0, 1, 7, 2, 6, 5, 3};
  std::vector<unsigned char> scratch(9 * 4, 0xAB);
  pool.permute(old_of_new, scratch.data());
  ASSERT_EQ(pool.size(), 9);
  for (int i = 0; i < 9; ++i) expect_tagged(pool, i, old_of_new[i]);
  EXPECT_EQ(pool.counters().created, before.created);
  EXPECT_EQ(pool.counters().removed, before.removed);
  // The identity leaves everything in place.
  const int32_t identity[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
  pool.permute(identity, scratch.data());
  for (int i = 0; i < 9; ++i) expect_tagged(pool, i, old_of_new[i]);
}

// A full pool of 10 (evict_unseen_frames 30) at frame 200:
//   tag 0..2  stable (confidence 20), last seen at frames 0, 20, 190 (ages 200, 180, 10): the first
//             two go after every unstable candidate, the third (seen recently) never
//   tag 3..6  unstable, ages 40, 100, 35, 50 (last_seen 160, 100, 165, 150)
//   tag 7..9  unstable, seen recently (age 5): not evictable
SurfelPool full_mixed_pool() {
  SurfelPool pool = make_sized_pool(10, 30);
  const int32_t last_seen[10] = {0, 20, 190, 160, 100, 165, 150, 195, 195, 195};
  for (int i = 0; i < 10; ++i) {
    append_tagged(pool, i);
    pool.confidence()[i] = i < 3 ? 20.0f : 2.0f;
    pool.last_seen()[i] = last_seen[i];
  }
  return pool;
}

// The tags (init_time - 1000) left in the pool, sorted.
std::vector<int> tags(const SurfelPool& pool) {
  std::vector<int> t;
  for (int64_t i = 0; i < pool.size(); ++i) t.push_back(pool.init_time()[i] - 1000);
  std::sort(t.begin(), t.end());
  return t;
}

TEST(SurfelPool, ReserveWithRoomEvictsNothing) {
  SurfelPool pool = make_sized_pool(10);
  for (int i = 0; i < 4; ++i) append_tagged(pool, i);
  EXPECT_EQ(pool.reserve_for_new(6, 500, 10.0f), 6);
  EXPECT_EQ(pool.reserve_for_new(0, 500, 10.0f), 0);
  EXPECT_EQ(pool.size(), 4);
  EXPECT_EQ(pool.counters().evicted, 0u);
}

TEST(SurfelPool, ReserveEvictsOldestUnstableFirst) {
  SurfelPool pool = full_mixed_pool();
  EXPECT_EQ(pool.reserve_for_new(3, 200, 10.0f), 3);
  // Ages 100 (tag 4), 50 (tag 6), 40 (tag 3) go; age 35 (tag 5) stays.
  EXPECT_EQ(tags(pool), (std::vector<int>{0, 1, 2, 5, 7, 8, 9}));
  EXPECT_EQ(pool.counters().evicted, 3u);
  EXPECT_EQ(pool.counters().removed, 0u);
  // The survivors' columns are intact wherever they moved.
  for (int64_t i = 0; i < pool.size(); ++i) {
    const int tag = pool.init_time()[i] - 1000;
    EXPECT_EQ(pool.x()[i], tagged(tag).x);
    EXPECT_EQ(std::memcmp(pool.labels() + i * kLabelBytes, tagged(tag).labels, kLabelBytes), 0);
  }
}

TEST(SurfelPool, ReserveOldestFirstWhenOlderSurfelsHaveLowerIds) {
  // The oldest candidate has the lowest id and an equally old pair above it: the oldest must still go.
  SurfelPool pool = make_sized_pool(3, 1);
  for (int i = 0; i < 3; ++i) {
    append_tagged(pool, i);
    pool.confidence()[i] = 1.0f;
  }
  pool.last_seen()[0] = 0;   // age 100
  pool.last_seen()[1] = 60;  // age 40
  pool.last_seen()[2] = 60;  // age 40
  EXPECT_EQ(pool.reserve_for_new(2, 100, 10.0f), 2);
  ASSERT_EQ(pool.size(), 1);
  EXPECT_EQ(pool.last_seen()[0], 60) << "the age-100 surfel must be evicted first";
}

TEST(SurfelPool, ReserveEvictsStableAfterUnstableNeverRecentAndReportsShortfall) {
  SurfelPool pool = full_mixed_pool();
  // 6 surfels are evictable: the 4 old unstable ones, then the stable ones by age (200 before 180).
  EXPECT_EQ(pool.reserve_for_new(5, 200, 10.0f), 5);
  EXPECT_EQ(tags(pool), (std::vector<int>{1, 2, 7, 8, 9}));
  EXPECT_EQ(pool.counters().evicted, 5u);
  // Asking for more than is evictable gives what there is; the caller counts the refusals.
  const int64_t got = pool.reserve_for_new(7, 200, 10.0f);
  EXPECT_EQ(got, 6);  // 5 free slots + the age-180 stable surfel
  pool.count_refused(static_cast<uint64_t>(7 - got));
  EXPECT_EQ(tags(pool), (std::vector<int>{2, 7, 8, 9}));
  EXPECT_EQ(pool.counters().evicted, 6u);
  EXPECT_EQ(pool.counters().refused, 1u);
  // Everything seen recently: no room, nothing removed.
  for (int i = 0; i < 6; ++i) append_tagged(pool, 20 + i), pool.last_seen()[pool.size() - 1] = 200;
  ASSERT_TRUE(pool.full());
  EXPECT_EQ(pool.reserve_for_new(3, 200, 10.0f), 0);
  EXPECT_EQ(pool.size(), 10);
  EXPECT_EQ(pool.counters().evicted, 6u);
}

TEST(SurfelPool, ReserveTreatsVeryOldSurfelsAsCandidates) {
  // Ages beyond the histogram's range (1024 frames) still count as the oldest.
  SurfelPool pool = make_sized_pool(4, 30);
  for (int i = 0; i < 4; ++i) {
    append_tagged(pool, i);
    pool.confidence()[i] = 1.0f;
  }
  pool.last_seen()[0] = 99'990;  // age 10: not evictable
  pool.last_seen()[1] = 0;       // age 100000
  pool.last_seen()[2] = 50'000;  // age 50000
  pool.last_seen()[3] = 99'900;  // age 100
  EXPECT_EQ(pool.reserve_for_new(2, 100'000, 10.0f), 2);
  ASSERT_EQ(pool.size(), 2);
  EXPECT_EQ(tags(pool), (std::vector<int>{0, 3}));
}

// Every block's box holds the centres of its surfels and its time range their last_seen, through
// append, set_position, set_last_seen, remove (a surfel moved into another block), permute,
// remove_flagged and a refresh after a mutable column was taken.
::testing::AssertionResult bounds_hold(const SurfelPool& pool) {
  if (!pool.bounds_current()) return ::testing::AssertionFailure() << "bounds stale";
  const SurfelPool& p = pool;
  for (int64_t i = 0; i < p.size(); ++i) {
    const SurfelPool::BlockBounds& b = p.block_bounds()[i / SurfelPool::kBoundsBlock];
    const float c[3] = {p.x()[i], p.y()[i], p.z()[i]};
    for (int a = 0; a < 3; ++a)
      if (!(b.lo[a] <= c[a] && c[a] <= b.hi[a]))
        return ::testing::AssertionFailure() << "surfel " << i << " axis " << a << " at " << c[a] << " outside ["
                                             << b.lo[a] << ", " << b.hi[a] << "]";
    if (!(b.seen_min <= p.last_seen()[i] && p.last_seen()[i] <= b.seen_max))
      return ::testing::AssertionFailure() << "surfel " << i << " last_seen " << p.last_seen()[i] << " outside ["
                                           << b.seen_min << ", " << b.seen_max << "]";
  }
  return ::testing::AssertionSuccess();
}

TEST(SurfelPool, BlockBoundsHoldTheirSurfelsThroughEveryWriter) {
  SurfelPool pool = make_sized_pool(5000);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> pos(-3.0f, 3.0f);
  for (int i = 0; i < 3000; ++i)
    pool.append(pos(rng), pos(rng), pos(rng), 0, 0, 1, 0.01f, 1.0f, 0, static_cast<int32_t>(i / 100));
  EXPECT_TRUE(bounds_hold(pool));
  EXPECT_EQ(pool.blocks(), (3000 + SurfelPool::kBoundsBlock - 1) / SurfelPool::kBoundsBlock);
  // The first block's box is tight after appends: the extremes of its surfels.
  {
    const SurfelPool& p = pool;
    float lo = p.x()[0], hi = p.x()[0];
    for (int i = 0; i < SurfelPool::kBoundsBlock; ++i) lo = std::min(lo, p.x()[i]), hi = std::max(hi, p.x()[i]);
    EXPECT_EQ(p.block_bounds()[0].lo[0], lo);
    EXPECT_EQ(p.block_bounds()[0].hi[0], hi);
    EXPECT_EQ(p.block_bounds()[0].seen_min, 0);
    EXPECT_EQ(p.block_bounds()[0].seen_max, 2);
  }
  std::uniform_int_distribution<int64_t> any(0, 2999);
  for (int k = 0; k < 500; ++k) {
    const int64_t id = any(rng) % pool.size();
    switch (k % 4) {
      case 0: pool.set_position(id, pos(rng) * 3, pos(rng) * 3, pos(rng) * 3); break;
      case 1: pool.set_last_seen(id, 1000 + k); break;
      case 2: pool.remove(id); break;
      default: pool.append(pos(rng), pos(rng), pos(rng), 0, 0, 1, 0.01f, 1.0f, 0, 2000 + k); break;
    }
  }
  EXPECT_TRUE(bounds_hold(pool));
  const uint64_t refreshes = pool.bounds_refreshes();

  // permute: every block has new members.
  std::vector<int32_t> order(static_cast<std::size_t>(pool.size()));
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int32_t>(order.size() - 1 - i);
  std::vector<unsigned char> scratch(4 * order.size());
  pool.permute(order.data(), scratch.data());
  EXPECT_TRUE(bounds_hold(pool));
  std::vector<uint8_t> flags(static_cast<std::size_t>(pool.size()), 0);
  for (std::size_t i = 0; i < flags.size(); i += 3) flags[i] = 1;
  pool.remove_flagged(flags.data());
  EXPECT_TRUE(bounds_hold(pool));
  EXPECT_EQ(pool.bounds_refreshes(), refreshes + 2);

  // A mutable column makes them stale (the caller may write anything); refresh recomputes them.
  float* x = pool.x();
  x[7] = 100.0f;
  EXPECT_FALSE(pool.bounds_current());
  EXPECT_FALSE(bounds_hold(pool));
  pool.refresh_bounds();
  EXPECT_TRUE(bounds_hold(pool));
  EXPECT_EQ(pool.block_bounds()[0].hi[0], 100.0f);
  EXPECT_EQ(pool.bounds_refreshes(), refreshes + 3);
  pool.refresh_bounds();  // current: nothing to do
  EXPECT_EQ(pool.bounds_refreshes(), refreshes + 3);
  // Reading through a const pool leaves them current.
  const SurfelPool& read = pool;
  EXPECT_EQ(read.x()[7], 100.0f);
  EXPECT_TRUE(pool.bounds_current());
}

}  // namespace
}  // namespace ef::slam
