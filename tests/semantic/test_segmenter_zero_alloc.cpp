// Segmenting a frame (resample, input, forward pass, argmax, upsampling) never touches the heap
// once the segmenter exists.
#include <gtest/gtest.h>

#include <vector>

#include "support/alloc_counter.h"
#include "semantic/segmenter.h"
#include "semantic/semantic_test_util.h"
#include "sources/open_source.h"

namespace ef {
namespace {

// Frames rendered before counting starts (the source allocates while rendering).
std::vector<Frame> frames(int width, int height, int count) {
  std::vector<Frame> out(static_cast<std::size_t>(count));
  auto src = open_source("synthetic:bedroom?frames=8&size=" + std::to_string(width) + "x" + std::to_string(height));
  EXPECT_TRUE(src.ok());
  for (Frame& f : out) {
    auto got = (*src)->next(f);
    EXPECT_TRUE(got.ok() && *got);
  }
  return out;
}

nn::Model tiny_model(uint32_t h, uint32_t w) {
  auto bytes = nn::serialize_model(test::tiny_seg_net(h, w));
  EXPECT_TRUE(bytes.ok());
  auto model = nn::load_model_memory(bytes->data(), bytes->size(), "tiny-seg.efm");
  EXPECT_TRUE(model.ok());
  return std::move(*model);
}

// 640x480 frames (an integer shrink to 160x120), 320x240 ones to a 24x32 input (10x: OpenCV in
// strips) and to a 25x33 one (a non-integer ratio, like the working frame to the real-camera
// network's 257x193: the area resampler's tables), upsampled back to the frame's size.
TEST(SegmenterZeroAlloc, SegmentAllocatesNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  for (auto [fw, fh, mh, mw] :
       {std::tuple<int, int, uint32_t, uint32_t>{640, 480, 120, 160}, {320, 240, 24, 32}, {320, 240, 25, 33}}) {
    const std::vector<Frame> input = frames(fw, fh, 3);
    const nn::Model model = tiny_model(mh, mw);
    semantic::SegmenterOptions o;
    o.frame_width = fw;  // announced, as RunSemantics does with the working size
    o.frame_height = fh;
    auto seg = semantic::Segmenter::create(model, o);
    ASSERT_TRUE(seg.ok()) << to_string(seg.error());
    Image<uint8_t> full(fw, fh), other(100, 70);
    ASSERT_TRUE((*seg)->segment(input[0], full.view()).ok());  // warm-up
    test::AllocationCounter count;
    for (int i = 0; i < 6; ++i) {
      EXPECT_TRUE((*seg)->segment(input[std::size_t(i % 3)], full.view()).ok());
      (*seg)->upsample_labels(other.view());
    }
    EXPECT_EQ(count.thread_allocations(), 0u) << fw << "x" << fh;
  }
}

// With a two-thread pool splitting the convolutions: no allocation on any thread.
TEST(SegmenterZeroAlloc, PooledSegmentAllocatesNothing) {
  const std::vector<Frame> input = frames(640, 480, 2);
  const nn::Model model = tiny_model(120, 160);
  ThreadPoolOptions po;
  po.threads = 2;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  semantic::SegmenterOptions o;
  o.pool = pool->get();
  auto seg = semantic::Segmenter::create(model, o);
  ASSERT_TRUE(seg.ok());
  Image<uint8_t> full(640, 480);
  ASSERT_TRUE((*seg)->segment(input[0], full.view()).ok());  // warm-up
  test::AllocationCounter count;
  for (int i = 0; i < 4; ++i) EXPECT_TRUE((*seg)->segment(input[std::size_t(i % 2)], full.view()).ok());
  EXPECT_EQ(count.global_allocations(), 0u);
}

}  // namespace
}  // namespace ef
