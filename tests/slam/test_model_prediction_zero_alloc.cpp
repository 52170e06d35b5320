// ModelPredictor::predict() must not touch the heap after create(), from the first call on (a pool
// of planes seen from several poses, stable and unstable surfels, every pyramid level). Lives in
// test_core because that binary has the counting operator new.
#include <gtest/gtest.h>

#include <cmath>

#include "support/alloc_counter.h"
#include "slam/model_prediction.h"
#include "slam/preprocess_test_util.h"
#include "slam/surfel_pool.h"

namespace ef {
namespace {

TEST(PredictionZeroAlloc, PredictAfterCreate) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  const Intrinsics K = test::kinect_320x240();
  slam::SurfelPoolOptions po;
  po.capacity = 60'000;
  auto pool = slam::SurfelPool::create(po);
  ASSERT_TRUE(pool.ok());
  // Two walls of surfels 5 mm apart, every 4th unstable, with a grey ramp.
  for (int i = 0; i < 200; ++i)
    for (int j = 0; j < 150; ++j)
      for (int wall = 0; wall < 2; ++wall) {
        const float x = -1.5f + 0.015f * static_cast<float>(i), y = -1.1f + 0.015f * static_cast<float>(j);
        const float z = wall == 0 ? 2.0f : 3.0f + 0.2f * x;
        const auto g = static_cast<uint8_t>(i);
        pool->append(x, y, z, 0.0f, 0.0f, -1.0f, 0.012f, (i + j) % 4 == 0 ? 3.0f : 12.0f, slam::pack_rgb(g, g, g), 0);
      }
  auto created = slam::ModelPredictor::create(K, 3);
  ASSERT_TRUE(created.ok());
  slam::ModelPredictor& predictor = *created;

  test::AllocationCounter count;
  for (int k = 0; k < 4; ++k) {
    Vector6d xi;
    xi << 0.05 * k, -0.02 * k, 0.1 * k, 0.01 * k, 0.03 * k, 0.0;
    ASSERT_TRUE(predictor.predict(*pool, SE3::exp(xi), k).ok());
    ASSERT_TRUE(predictor.predict(*pool, SE3::exp(xi), k, 2.0f).ok());
  }
  EXPECT_EQ(count.thread_allocations(), 0u);
  EXPECT_EQ(count.global_allocations(), 0u);
  // The calls did real work.
  EXPECT_GT(predictor.counters().valid_pixels, K.width * K.height / 2);
  EXPECT_GT(predictor.index_map().surfels_drawn, 10'000);
}

}  // namespace
}  // namespace ef
