// DenseCrf::run (lattice construction, mean-field iterations, write-back) never touches the heap once
// the DenseCrf exists.
#include <gtest/gtest.h>

#include <random>

#include "support/alloc_counter.h"
#include "semantic/dense_crf.h"
#include "semantic/label_store.h"
#include "slam/surfel_pool.h"

namespace ef {
namespace {

TEST(CrfZeroAlloc, RunAllocatesNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  slam::SurfelPoolOptions po;
  po.capacity = 2000;
  auto pool = slam::SurfelPool::create(po);
  ASSERT_TRUE(pool.ok());
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 0.4f);
  for (int i = 0; i < 1500; ++i) {
    const int64_t id = pool->append(u(rng), u(rng), 0.0f, 0, 0, 1, 0.005f, 20,
                                    slam::pack_rgb(uint8_t(rng() % 256), 100, 50), 0);
    float probs[semantic::kLabelClasses];
    for (float& p : probs) p = 0.01f + float(rng() % 100) / 100.0f;
    semantic::encode_labels(probs, pool->labels() + id * semantic::kLabelBytes);
  }
  semantic::DenseCrfOptions o;
  o.capacity = 2000;
  o.iterations = 3;
  o.max_lattice_vertices = 7 * 2000;  // every simplex fits
  auto crf = semantic::DenseCrf::create(o);
  ASSERT_TRUE(crf.ok());
  ASSERT_TRUE(crf->run(*pool).ok());  // a first run, as a warm-up

  // Checked after counting: a failing EXPECT allocates its message.
  test::AllocationCounter count;
  bool ok = true;
  int64_t updated = 0;
  for (int k = 0; k < 2; ++k) {
    auto r = crf->run(*pool);
    ok = ok && r.ok();
    if (r.ok()) updated += r->surfels_updated;
  }
  const uint64_t allocations = count.thread_allocations();
  EXPECT_TRUE(ok);
  EXPECT_EQ(updated, 2 * 1500);
  EXPECT_EQ(allocations, 0u);

  // A full lattice (surfels left out) allocates nothing either.
  o.max_lattice_vertices = 30;
  auto small = semantic::DenseCrf::create(o);
  ASSERT_TRUE(small.ok());
  count.restart();
  auto r = small->run(*pool);
  const uint64_t allocations_full = count.thread_allocations();
  ASSERT_TRUE(r.ok());
  EXPECT_GT(r->surfels_left_out, 0);
  EXPECT_EQ(allocations_full, 0u);
}

}  // namespace
}  // namespace ef
