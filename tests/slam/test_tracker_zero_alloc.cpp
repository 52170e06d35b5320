// Tracker::track() must not touch the heap after warm-up (the first call dispatches the reduction
// kernel). Lives in test_core because that binary has the counting operator new.
#include <gtest/gtest.h>

#include "support/alloc_counter.h"
#include "slam/preprocess.h"
#include "slam/preprocess_test_util.h"
#include "slam/tracker.h"

namespace ef {
namespace {

TEST(TrackerZeroAlloc, TrackAfterWarmUp) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  const Intrinsics K = test::kinect_320x240();
  Frame a, b;
  test::render_plane(a, K, 1.5, 20, 10);
  test::render_plane(b, K, 1.55, 22, 9);
  for (int y = 0; y < K.height; ++y)
    for (int x = 0; x < K.width; ++x) {
      a.color(x, y) = Rgb8{static_cast<uint8_t>(x), static_cast<uint8_t>(y), 7};
      b.color(x, y) = Rgb8{static_cast<uint8_t>(x + 1), static_cast<uint8_t>(y), 7};
    }
  auto pa = slam::Preprocessor::create(K);
  auto pb = slam::Preprocessor::create(K);
  ASSERT_TRUE(pa.ok() && pb.ok());
  ASSERT_TRUE(pa->process(a).ok());
  ASSERT_TRUE(pb->process(b).ok());
  auto created = slam::Tracker::create(K, 3);
  ASSERT_TRUE(created.ok());
  slam::Tracker& tracker = *created;
  slam::TrackResult r;
  const slam::PyramidView va = slam::pyramid_view(*pa), vb = slam::pyramid_view(*pb);
  ASSERT_TRUE(tracker.track(va, vb, SE3(), &r).ok());  // warm-up

  test::AllocationCounter count;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(tracker.track(va, vb, SE3(), &r).ok());
    ASSERT_TRUE(tracker.track(vb, va, r.T_ref_cur, &r).ok());
  }
  EXPECT_EQ(count.thread_allocations(), 0u);
  EXPECT_EQ(count.global_allocations(), 0u);
}

}  // namespace
}  // namespace ef
