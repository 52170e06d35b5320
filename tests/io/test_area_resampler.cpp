// AreaResampler (io/area_resampler.h): the box filter at any ratio, with its tables made at creation.
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

#include <opencv2/imgproc.hpp>

#include "io/area_resampler.h"

namespace ef {
namespace {

Image<Rgb8> random_image(int w, int h, uint32_t seed) {
  Image<Rgb8> im(w, h);
  std::mt19937 rng(seed);
  for (std::size_t i = 0; i < im.size(); ++i)
    im.data()[i] = Rgb8{uint8_t(rng() & 255), uint8_t(rng() & 255), uint8_t(rng() & 255)};
  return im;
}

TEST(AreaResampler, IntegerShrinkIsTheBlockMean) {
  const Image<Rgb8> src = random_image(12, 8, 1);
  auto r = AreaResampler::create(12, 8, 4, 2);
  ASSERT_TRUE(r.ok());
  Image<Rgb8> dst(4, 2);
  ASSERT_TRUE(r->run(src.view(), dst.view()));
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      int sum = 0;
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 3; ++i) sum += src(3 * x + i, 4 * y + j).g;
      EXPECT_NEAR(dst(x, y).g, sum / 12.0, 0.5 + 1e-3) << x << "," << y;
    }
}

TEST(AreaResampler, ConstantStaysConstantAtAnyRatio) {
  Image<Rgb8> src(320, 240);
  for (std::size_t i = 0; i < src.size(); ++i) src.data()[i] = Rgb8{7, 128, 255};
  for (auto [w, h] : {std::pair<int, int>{257, 193}, {161, 121}, {33, 25}, {400, 300}}) {
    auto r = AreaResampler::create(320, 240, w, h);
    ASSERT_TRUE(r.ok());
    Image<Rgb8> dst(w, h);
    ASSERT_TRUE(r->run(src.view(), dst.view()));
    for (std::size_t i = 0; i < dst.size(); ++i) {
      ASSERT_EQ(dst.data()[i].r, 7) << w << "x" << h;
      ASSERT_EQ(dst.data()[i].g, 128);
      ASSERT_EQ(dst.data()[i].b, 255);
    }
  }
}

// The same filter as OpenCV's INTER_AREA shrink (which `convert --resolution` uses), to within its
// fixed-point rounding.
TEST(AreaResampler, MatchesOpenCvAreaWithinOneLevel) {
  const Image<Rgb8> src = random_image(320, 240, 3);
  for (auto [w, h] : {std::pair<int, int>{257, 193}, {161, 121}, {100, 75}}) {
    auto r = AreaResampler::create(320, 240, w, h);
    ASSERT_TRUE(r.ok());
    Image<Rgb8> dst(w, h), ref(w, h);
    ASSERT_TRUE(r->run(src.view(), dst.view()));
    const cv::Mat in(240, 320, CV_8UC3, const_cast<Rgb8*>(src.data()));
    cv::Mat out(h, w, CV_8UC3, ref.data());
    cv::resize(in, out, out.size(), 0, 0, cv::INTER_AREA);
    int worst = 0;
    for (std::size_t i = 0; i < dst.size(); ++i)
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::abs(int((&dst.data()[i].r)[c]) - int((&ref.data()[i].r)[c])));
    EXPECT_LE(worst, 1) << w << "x" << h;
  }
}

TEST(AreaResampler, RefusesBadSizesAndMismatchedImages) {
  EXPECT_FALSE(AreaResampler::create(0, 240, 10, 10).ok());
  EXPECT_FALSE(AreaResampler::create(320, 240, 10, 100000).ok());
  auto r = AreaResampler::create(320, 240, 257, 193);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->bytes(), AreaResampler::bytes_for(320, 240, 257, 193));
  Image<Rgb8> src(321, 240), dst(257, 193);
  EXPECT_FALSE(r->run(src.view(), dst.view()));
}

}  // namespace
}  // namespace ef
