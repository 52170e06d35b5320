// Label images: palette colours (typed in from the paper's colour table) and raw class-id PNGs.
#include <gtest/gtest.h>

#include "core/classes.h"
#include "io/image_codec.h"
#include "io/label_image.h"
#include "test_support.h"

namespace ef {
namespace {

TEST(OutputsLabelPng, PaletteColoursRoundTrip) {
  // ids 0..13 then an invalid id 200 (black), on a 5x3 image.
  Image<uint8_t> labels(5, 3);
  for (int i = 0; i < 14; ++i) labels.data()[i] = static_cast<uint8_t>(i);
  labels.data()[14] = 200;
  const Rgb8 expected[15] = {
      {0, 0, 0},       {0, 128, 128},   {250, 50, 50},   {102, 0, 204},   {50, 50, 250},
      {230, 230, 237}, {255, 69, 20},   {255, 20, 127},  {50, 50, 150},   {222, 180, 140},
      {50, 250, 50},   {255, 215, 0},   {150, 150, 150}, {0, 255, 255},   {0, 0, 0}};
  const auto dir = test::scratch_dir("label_png");
  const std::string path = (dir / "labels_color.png").string();
  Image<Rgb8> scratch;
  ASSERT_TRUE(write_label_png_color(path, labels.cview(), scratch).ok());
  Image<Rgb8> back;
  ASSERT_TRUE(read_color_image(path, back).ok());
  ASSERT_EQ(back.width(), 5);
  ASSERT_EQ(back.height(), 3);
  for (int i = 0; i < 15; ++i) {
    const Rgb8 c = back.data()[i];
    EXPECT_EQ(c, expected[i]) << "id " << int(labels.data()[i]) << ": got " << int(c.r) << "," << int(c.g) << ","
                              << int(c.b);
  }
  // The scratch image is reused for the same size.
  const Rgb8* before = scratch.data();
  ASSERT_TRUE(write_label_png_color(path, labels.cview(), scratch).ok());
  EXPECT_EQ(scratch.data(), before);
}

TEST(OutputsLabelPng, RawIdsRoundTrip) {
  Image<uint8_t> labels(7, 2);
  for (int i = 0; i < 14; ++i) labels.data()[i] = static_cast<uint8_t>((i * 5) % 14);
  const std::string path = (test::scratch_dir("label_ids") / "0001.png").string();
  ASSERT_TRUE(write_label_png_ids(path, labels.cview()).ok());
  Image<uint8_t> back;
  ASSERT_TRUE(read_png_u8(path, back).ok());
  ASSERT_EQ(back.width(), 7);
  for (int i = 0; i < 14; ++i) EXPECT_EQ(back.data()[i], labels.data()[i]);
  EXPECT_FALSE(write_label_png_ids(path, ImageView<const uint8_t>()).ok());
}

TEST(OutputsLabelPng, ColorizeRejectsSizeMismatch) {
  Image<uint8_t> labels(2, 2);
  Image<Rgb8> out(3, 2);
  EXPECT_FALSE(colorize_labels(labels.cview(), out.view()));
  Image<Rgb8> ok(2, 2);
  labels(1, 1) = kTv;
  EXPECT_TRUE(colorize_labels(labels.cview(), ok.view()));
  EXPECT_EQ(ok(1, 1), (Rgb8{255, 215, 0}));
}

}  // namespace
}  // namespace ef
