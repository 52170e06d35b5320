// slam/depth_pyramid: the coarse-depth rule shared by the frame's and the predicted pyramids.
#include <gtest/gtest.h>

#include "slam/depth_pyramid.h"

namespace ef::slam {
namespace {

constexpr float kThr = 0.09f;  // PreprocessOptions / PredictionOptions default, metres

TEST(DepthPyramid, KeepsAPlaneTakesOneSurfaceAtAStepAndLeavesHoles) {
  Image<float> fine;
  fine.allocate(16, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) fine(x, y) = x < 8 ? 1.0f : 3.0f;  // a 2 m step between columns 7 and 8
  for (int x = 0; x < 4; ++x) fine(x, 4) = fine(x, 5) = 0.0f;     // coarse row 2, columns 0 and 1: no depth
  Image<float> coarse;
  coarse.allocate(8, 4);
  downsample_depth(fine, coarse, kThr);
  EXPECT_EQ(coarse(0, 2), 0.0f);  // a block without depth stays a hole
  EXPECT_EQ(coarse(1, 2), 0.0f);
  for (int y = 0; y < 4; ++y) {
    EXPECT_EQ(coarse(3, y), 1.0f) << y;  // next to the step: only the near side's depths
    EXPECT_EQ(coarse(4, y), 3.0f) << y;  // and only the far side's
    EXPECT_EQ(coarse(6, y), 3.0f) << y;
  }
  EXPECT_EQ(coarse(2, 0), 1.0f);  // border pixels: taps outside the image are left out
  EXPECT_EQ(coarse(7, 3), 3.0f);
}

// The predictor's pyramid: intensity from the finer pixels with depth only, none where the coarse
// pixel has no depth; border and interior pixels (kernels/pyramid_row) alike.
TEST(DepthPyramid, IntensityComesFromPixelsWithDepthOnly) {
  Image<float> fine, grey;
  fine.allocate(20, 12);
  grey.allocate(20, 12);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 20; ++x) {
      const bool hole = (x + y) % 5 == 0 && !(x >= 8 && x < 12 && y >= 4 && y < 8);
      fine(x, y) = hole ? 0.0f : 2.0f;
      grey(x, y) = hole ? 1.0e6f : 100.0f;  // what a hole holds must not leak in
    }
  for (int y = 4; y < 6; ++y)
    for (int x = 14; x < 16; ++x) fine(x, y) = 0.0f;  // coarse (7, 2): its block has no depth
  Image<float> coarse, coarse_grey, depth_only;
  coarse.allocate(10, 6);
  coarse_grey.allocate(10, 6);
  depth_only.allocate(10, 6);
  downsample_depth_intensity(fine, grey, coarse, coarse_grey, kThr);
  downsample_depth(fine, depth_only, kThr);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 10; ++x) {
      EXPECT_EQ(coarse(x, y), depth_only(x, y)) << x << ", " << y;
      if (x == 7 && y == 2) {
        EXPECT_EQ(coarse(x, y), 0.0f);
        EXPECT_EQ(coarse_grey(x, y), 0.0f);
      } else {
        EXPECT_EQ(coarse(x, y), 2.0f) << x << ", " << y;
        EXPECT_EQ(coarse_grey(x, y), 100.0f) << x << ", " << y;
      }
    }
}

}  // namespace
}  // namespace ef::slam
