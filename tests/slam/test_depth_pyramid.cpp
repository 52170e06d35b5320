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

}  // namespace
}  // namespace ef::slam
