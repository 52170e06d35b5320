// The SLAM frame path must not touch the heap after warm-up: Preprocessor::process() and the
// Gauss-Newton reduction. Lives in test_core because that binary has the counting operator new.
#include <gtest/gtest.h>

#include <vector>

#include "support/alloc_counter.h"
#include "kernels/normal_equations.h"
#include "slam/preprocess.h"
#include "slam/preprocess_test_util.h"

namespace ef {
namespace {

TEST(SlamZeroAlloc, PreprocessAndReductionAfterWarmUp) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  const Intrinsics K = test::kinect_320x240();
  Frame a, b;
  test::render_plane(a, K, 1.5, 20, 10);
  test::render_plane(b, K, 2.5, -10, 30);
  test::add_noise(b.depth, 0.005f, 1);
  for (int y = 0; y < K.height; ++y)
    for (int x = 0; x < K.width; ++x) a.color(x, y) = Rgb8{static_cast<uint8_t>(x), static_cast<uint8_t>(y), 7};
  auto created = slam::Preprocessor::create(K);
  ASSERT_TRUE(created.ok());
  slam::Preprocessor& p = *created;
  std::vector<float> rows(8 * 1000, 0.5f);
  kernels::NormalEquations ne;
  // Warm-up: the first frame and the first dispatched call (which picks the variant once).
  ASSERT_TRUE(p.process(a).ok());
  kernels::reduce_normal_equations(rows.data(), 1000, 1000, &ne);

  test::AllocationCounter count;
  for (int i = 0; i < 6; ++i) {
    ASSERT_TRUE(p.process(i % 2 ? a : b).ok());
    ASSERT_TRUE(p.process(b.depth.view(), ImageView<const Rgb8>()).ok());  // no colour
    kernels::reduce_normal_equations(rows.data(), 1000, 1000 - i, &ne);
  }
  EXPECT_EQ(count.thread_allocations(), 0u);
  EXPECT_EQ(count.global_allocations(), 0u);
}

}  // namespace
}  // namespace ef
