// resample_frame: the working-resolution images keep the geometry of the source images.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "io/frame_resample.h"
#include "io/frame_source.h"
#include "synth/synthetic_source.h"

namespace ef {
namespace {

TEST(Resample, DepthBlocksKeepTheNearSurfaceAndSkipInvalid) {
  Frame src, dst;
  src.allocate(4, 2, true);
  dst.allocate(2, 1, true);
  // Block 0: 1.00, 1.02 (near surface) and 2.0, 0 (far surface, invalid) -> mean of the near ones.
  src.depth(0, 0) = 1.00f; src.depth(1, 0) = 2.0f; src.depth(0, 1) = 1.02f; src.depth(1, 1) = 0.0f;
  // Block 1: all invalid -> invalid.
  for (int y = 0; y < 2; ++y) for (int x = 2; x < 4; ++x) src.depth(x, y) = 0.0f;
  src.labels.fill(7);
  src.labels(3, 1) = 9;
  src.has_labels = true;
  src.has_pose = true;
  src.timestamp = 12.5;
  src.index = 42;
  src.name = "frame-000042";
  src.T_wc = SE3::exp((Vector6d() << 0.1, 0.2, 0.3, 0.01, 0.02, 0.03).finished());
  src.color.fill(Rgb8{10, 20, 30});
  src.color(0, 0) = Rgb8{50, 20, 30};

  resample_frame(src, dst);
  EXPECT_FLOAT_EQ(dst.depth(0, 0), 1.01f);
  EXPECT_EQ(dst.depth(1, 0), 0.0f);
  EXPECT_EQ(dst.color(0, 0), (Rgb8{20, 20, 30}));  // area average of 50, 10, 10, 10
  EXPECT_EQ(dst.color(1, 0), (Rgb8{10, 20, 30}));
  EXPECT_EQ(dst.labels(0, 0), 7);
  EXPECT_TRUE(dst.has_labels);
  EXPECT_TRUE(dst.has_pose);
  EXPECT_EQ(dst.timestamp, 12.5);
  EXPECT_EQ(dst.index, 42);
  EXPECT_EQ(dst.name, "frame-000042");
  EXPECT_TRUE(dst.T_wc.translation().isApprox(src.T_wc.translation()));
}

// Rendering a room at 640x480 and resampling to 320x240 must agree with rendering it at 320x240
// with the scaled intrinsics: this checks the pixel-centre convention of Intrinsics::scaled_to and
// of the resampler together.
TEST(Resample, AgreesWithRenderingAtTheWorkingResolution) {
  auto big = synth::open_synthetic_source(*synth::parse_synthetic_options(*parse_source_uri("synthetic:office?noise=0&frames=3")), "big");
  auto small = synth::open_synthetic_source(
      *synth::parse_synthetic_options(*parse_source_uri("synthetic:office?noise=0&frames=3&size=320x240")), "small");
  ASSERT_TRUE(big.ok() && small.ok());
  Frame fb, fs, resampled;
  fb.allocate(640, 480, true);
  fs.allocate(320, 240, true);
  resampled.allocate(320, 240, true);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(*(*big)->next(fb));
    ASSERT_TRUE(*(*small)->next(fs));
    resample_frame(fb, resampled);
    std::vector<float> err;
    int label_agree = 0, both = 0;
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 320; ++x) {
        const float a = resampled.depth(x, y), b = fs.depth(x, y);
        if (a > 0 && b > 0) err.push_back(std::abs(a - b) / b);
        ++both;
        label_agree += resampled.labels(x, y) == fs.labels(x, y);
      }
    ASSERT_GT(err.size(), 320u * 240u / 2);
    std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
    EXPECT_LT(err[err.size() / 2], 0.002) << "frame " << i;  // median relative depth difference
    std::nth_element(err.begin(), err.begin() + err.size() * 9 / 10, err.end());
    EXPECT_LT(err[err.size() * 9 / 10], 0.01) << "frame " << i;
    // Labels only differ along class boundaries: 0.6-0.7% of pixels with the half-pixel-centre
    // convention; a quarter-pixel error (cx' = cx * s) doubles that to about 1.3%.
    EXPECT_LT(both - label_agree, both * 9 / 1000) << "frame " << i;
  }
}

}  // namespace
}  // namespace ef
