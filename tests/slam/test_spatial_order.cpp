// SpatialOrder: after reorder() the pool's surfels are grouped by cell in Morton order, every surfel
// is still there with all its columns, surfels of one cell keep their order; no allocation; bad
// options and a pool beyond the capacity are errors; the schedule.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "support/alloc_counter.h"
#include "slam/spatial_order.h"
#include "slam/surfel_pool.h"

namespace ef::slam {
namespace {

SurfelPool make_order_pool(int64_t capacity) {
  SurfelPoolOptions o;
  o.capacity = capacity;
  auto p = SurfelPool::create(o);
  EXPECT_TRUE(p.ok()) << to_string(p.error());
  return std::move(p).value();
}

// The Morton key of the cell holding (x, y, z), written here independently of the implementation:
// bit b of the wrapped cell coordinate of axis a goes to bit 3 b + a.
uint32_t cell_key(float x, float y, float z, float cell_m) {
  const float v[3] = {x, y, z};
  uint32_t key = 0;
  for (int a = 0; a < 3; ++a) {
    const auto c = static_cast<uint32_t>(static_cast<int32_t>(std::floor(v[a] / cell_m))) & 63u;
    for (int b = 0; b < 6; ++b) key |= ((c >> b) & 1u) << (3 * b + a);
  }
  return key;
}

// n surfels scattered over a 3 m box around the origin (negative coordinates included, so that the
// wrap of cell coordinates is exercised), each tagged by init_time = its original id and with labels
// and colour derived from it.
void fill_random(SurfelPool& pool, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.5f, 1.5f);
  for (int i = 0; i < n; ++i) {
    const int64_t id = pool.append(pos(rng), pos(rng), pos(rng), 0.0f, 0.0f, 1.0f, 0.01f + 1e-6f * static_cast<float>(i),
                                   1.0f + static_cast<float>(i), 0x10101u * static_cast<uint32_t>(i % 200), i);
    ASSERT_EQ(id, i);
    pool.last_seen()[id] = 5000 + i;
    for (int k = 0; k < SurfelPool::kLabelBytesPerSurfel; ++k)
      pool.labels()[id * SurfelPool::kLabelBytesPerSurfel + k] = static_cast<uint8_t>(i * 7 + k);
  }
}

struct Snapshot {
  float x, y, z, radius, confidence;
  uint32_t color;
  int32_t last_seen;
  uint8_t labels[SurfelPool::kLabelBytesPerSurfel];
};

std::vector<Snapshot> snapshot(const SurfelPool& pool) {
  std::vector<Snapshot> s(static_cast<std::size_t>(pool.size()));
  for (int64_t i = 0; i < pool.size(); ++i) {
    Snapshot& t = s[static_cast<std::size_t>(i)];
    t = {pool.x()[i], pool.y()[i], pool.z()[i], pool.radius()[i], pool.confidence()[i], pool.color()[i], pool.last_seen()[i], {}};
    std::memcpy(t.labels, pool.labels() + i * SurfelPool::kLabelBytesPerSurfel, SurfelPool::kLabelBytesPerSurfel);
  }
  return s;
}

TEST(SpatialOrder, GroupsSurfelsByCellAndKeepsEverySurfelWhole) {
  constexpr int kN = 5000;
  SurfelPool pool = make_order_pool(kN);
  fill_random(pool, kN, 3);
  const std::vector<Snapshot> before = snapshot(pool);
  SpatialOrderOptions o;
  o.cell_m = 0.1f;
  auto order = SpatialOrder::create(kN, o);
  ASSERT_TRUE(order.ok()) << to_string(order.error());
  ASSERT_TRUE(order->reorder(pool).ok());
  ASSERT_EQ(pool.size(), kN);

  std::vector<int> seen(kN, 0);
  uint32_t last_key = 0;
  int32_t last_tag = -1;
  int64_t cells = 0;
  for (int64_t i = 0; i < kN; ++i) {
    const int32_t tag = pool.init_time()[i];  // the surfel's id before the reorder
    ASSERT_GE(tag, 0);
    ASSERT_LT(tag, kN);
    ++seen[tag];
    const Snapshot& b = before[static_cast<std::size_t>(tag)];
    EXPECT_EQ(pool.x()[i], b.x);
    EXPECT_EQ(pool.y()[i], b.y);
    EXPECT_EQ(pool.z()[i], b.z);
    EXPECT_EQ(pool.radius()[i], b.radius);
    EXPECT_EQ(pool.confidence()[i], b.confidence);
    EXPECT_EQ(pool.color()[i], b.color);
    EXPECT_EQ(pool.last_seen()[i], b.last_seen);
    EXPECT_EQ(std::memcmp(pool.labels() + i * SurfelPool::kLabelBytesPerSurfel, b.labels, SurfelPool::kLabelBytesPerSurfel), 0)
        << "labels of slot " << i;
    const uint32_t key = cell_key(pool.x()[i], pool.y()[i], pool.z()[i], o.cell_m);
    if (i > 0) {
      ASSERT_GE(key, last_key) << "slot " << i << ": cells out of Morton order";
      if (key == last_key) {
        EXPECT_GT(tag, last_tag) << "slot " << i << ": order within a cell not kept";
      }
    }
    cells += (i == 0 || key != last_key) ? 1 : 0;
    last_key = key;
    last_tag = tag;
  }
  for (int t = 0; t < kN; ++t) EXPECT_EQ(seen[t], 1) << "surfel " << t;
  // 27,000 cells of 10 cm in the 3 m box: most of the 5000 surfels are alone in theirs, so the test
  // above really checks an ordering (not one big bucket).
  EXPECT_GT(cells, 4000);
  EXPECT_EQ(pool.counters().removed, 0u);
}

TEST(SpatialOrder, ReorderOfAnOrderedPoolChangesNothingAndAllocatesNothing) {
  constexpr int kN = 3000;
  SurfelPool pool = make_order_pool(kN + 10);
  fill_random(pool, kN, 11);
  auto order = SpatialOrder::create(kN + 10);
  ASSERT_TRUE(order.ok());
  ASSERT_TRUE(order->reorder(pool).ok());
  const std::vector<Snapshot> once = snapshot(pool);
  std::vector<int32_t> tags(pool.init_time(), pool.init_time() + kN);
  test::AllocationCounter count;
  ASSERT_TRUE(order->reorder(pool).ok());
  EXPECT_EQ(count.thread_allocations(), 0u);
  for (int64_t i = 0; i < kN; ++i) ASSERT_EQ(pool.init_time()[i], tags[static_cast<std::size_t>(i)]) << "slot " << i;
  const std::vector<Snapshot> twice = snapshot(pool);
  EXPECT_EQ(std::memcmp(once.data(), twice.data(), once.size() * sizeof(Snapshot)), 0);
}

TEST(SpatialOrder, EmptyPoolAndPoolBeyondCapacity) {
  SurfelPool pool = make_order_pool(100);
  auto small = SpatialOrder::create(10);
  ASSERT_TRUE(small.ok());
  EXPECT_TRUE(small->reorder(pool).ok());  // empty: nothing to do
  fill_random(pool, 20, 5);
  const std::vector<Snapshot> before = snapshot(pool);
  const Status s = small->reorder(pool);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(to_string(s.error()).find("capacity 10"), std::string::npos) << to_string(s.error());
  const std::vector<Snapshot> after = snapshot(pool);
  EXPECT_EQ(std::memcmp(before.data(), after.data(), before.size() * sizeof(Snapshot)), 0) << "pool changed";
}

TEST(SpatialOrder, OptionsAndSchedule) {
  SpatialOrderOptions o;
  EXPECT_TRUE(o.validate().ok());
  o.every_frames = -1;
  EXPECT_NE(to_string(o.validate().error()).find("every_frames"), std::string::npos);
  o.every_frames = 30;
  for (float bad : {0.0f, -0.1f, NAN, INFINITY}) {
    o.cell_m = bad;
    ASSERT_FALSE(o.validate().ok()) << bad;
    EXPECT_NE(to_string(o.validate().error()).find("cell_m"), std::string::npos);
  }
  EXPECT_FALSE(SpatialOrder::create(0).ok());

  o = SpatialOrderOptions{};
  o.every_frames = 30;
  auto order = SpatialOrder::create(10, o);
  ASSERT_TRUE(order.ok());
  std::vector<int64_t> due;
  for (int64_t f = 0; f < 100; ++f)
    if (order->due(f)) due.push_back(f);
  EXPECT_EQ(due, (std::vector<int64_t>{29, 59, 89}));
  o.every_frames = 0;
  order = SpatialOrder::create(10, o);
  ASSERT_TRUE(order.ok());
  for (int64_t f = 0; f < 100; ++f) EXPECT_FALSE(order->due(f));
  EXPECT_EQ(order->bytes(), SpatialOrder::bytes_for(10));
  EXPECT_EQ(SpatialOrder::bytes_for(1000), 8000u + SpatialOrder::kKeys * 4u);
}

}  // namespace
}  // namespace ef::slam
