// LabelFusion::fuse (observation vectors, index-map walk, the update kernel) never touches the heap
// once the LabelFusion exists.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "support/alloc_counter.h"
#include "semantic/label_fusion.h"
#include "semantic/label_store.h"
#include "slam/index_map.h"
#include "slam/surfel_pool.h"

namespace ef {
namespace {

TEST(LabelFusionZeroAlloc, FuseAllocatesNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  semantic::LabelFusionOptions opt;  // 320x240 working, 160x120 CNN
  auto fusion = semantic::LabelFusion::create(opt);
  ASSERT_TRUE(fusion.ok());
  slam::SurfelPoolOptions po;
  po.capacity = 20000;
  auto pool = slam::SurfelPool::create(po);
  ASSERT_TRUE(pool.ok());
  for (int i = 0; i < 20000; ++i) pool->append(0, 0, 1, 0, 0, -1, 0.01f, 1, 0, 0);
  slam::IndexMap index;
  index.scale = 4;
  index.id.allocate(1280, 960);
  index.id.fill(-1);
  index.depth.allocate(1280, 960);
  std::mt19937 rng(3);
  for (int i = 0; i < 20000; ++i) {
    const int x = int(rng() % 1280), y = int(rng() % 960);
    index.id(x, y) = i;
    index.depth(x, y) = (i % 3 == 0) ? 2.5f : 2.0f;  // a third are hidden behind the measured surface
  }
  Image<float> depth(320, 240);
  depth.fill(2.0f);
  std::vector<float> probs(160 * 120 * semantic::kLabelClasses);
  for (float& p : probs) p = 0.01f + float(rng() % 1000) / 1000.0f;
  const semantic::ProbabilityView view{probs.data(), 120, 160, semantic::kLabelClasses};
  ASSERT_TRUE(fusion->fuse(index, view, *pool).ok());  // first call: dispatch is chosen

  test::AllocationCounter count;
  for (int k = 0; k < 3; ++k) {
    auto r = fusion->fuse(index, view, *pool);
    ASSERT_TRUE(r.ok());
    EXPECT_GT(r->surfels_updated, 0);
    auto gated = fusion->fuse(index, view, *pool, depth.view());  // with the visibility test
    ASSERT_TRUE(gated.ok());
    EXPECT_GT(gated->hidden_skipped, 0);
  }
  EXPECT_EQ(count.thread_allocations(), 0u);
}

}  // namespace
}  // namespace ef
