#include <gtest/gtest.h>

#include <cstdlib>

#include "io/image_codec.h"
#include "io_test_util.h"
#include "test_support.h"

namespace ef {
namespace {

TEST(ImageCodec, PngRoundTripsRgbGray8AndGray16) {
  const auto dir = test::scratch_dir("codec_png");
  Frame f = test::make_frame(37, 23, 3);
  Image<uint16_t> d16(37, 23);
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 37; ++x) d16(x, y) = uint16_t(x * 1000 + y * 7 + 1);  // high and low bytes differ
  ASSERT_TRUE(write_png((dir / "c.png").string(), f.color.cview()).ok());
  ASSERT_TRUE(write_png((dir / "l.png").string(), f.labels.cview()).ok());
  ASSERT_TRUE(write_png((dir / "d.png").string(), d16.cview()).ok());
  Image<Rgb8> c;
  Image<uint8_t> l;
  Image<uint16_t> d;
  ASSERT_TRUE(read_color_image((dir / "c.png").string(), c).ok());
  ASSERT_TRUE(read_png_u8((dir / "l.png").string(), l).ok());
  ASSERT_TRUE(read_png_u16((dir / "d.png").string(), d).ok());
  ASSERT_EQ(c.width(), 37);
  ASSERT_EQ(d.height(), 23);
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 37; ++x) {
      EXPECT_EQ(c(x, y), f.color(x, y));
      EXPECT_EQ(l(x, y), f.labels(x, y));
      EXPECT_EQ(d(x, y), d16(x, y));
    }
  // Reading a same-sized file again does not reallocate.
  const uint16_t* before = d.data();
  ASSERT_TRUE(read_png_u16((dir / "d.png").string(), d).ok());
  EXPECT_EQ(before, d.data());
  // A gray PNG reads as colour too.
  ASSERT_TRUE(read_color_image((dir / "l.png").string(), c).ok());
  EXPECT_EQ(c(5, 5).r, f.labels(5, 5));
}

TEST(ImageCodec, EightBitDepthPngIsAnErrorNamingTheFile) {
  const auto dir = test::scratch_dir("codec_8bit");
  Image<uint8_t> g(8, 8);
  const std::string path = (dir / "depth8.png").string();
  ASSERT_TRUE(write_png(path, g.cview()).ok());
  Image<uint16_t> d;
  EXPECT_ERROR_WITH(read_png_u16(path, d), ErrorCode::kUnsupported, path, "16-bit", "8-bit gray");
  Image<uint16_t> d16(8, 8);
  ASSERT_TRUE(write_png(path, d16.cview()).ok());
  Image<uint8_t> l;
  EXPECT_ERROR_WITH(read_png_u8(path, l), ErrorCode::kUnsupported, path, "8-bit");
}

TEST(ImageCodec, MissingTruncatedAndNonImageFiles) {
  const auto dir = test::scratch_dir("codec_bad");
  Image<Rgb8> c;
  const std::string missing = (dir / "nope.png").string();
  EXPECT_ERROR_WITH(read_color_image(missing, c), ErrorCode::kNotFound, missing);
  Frame f = test::make_frame(64, 48, 1);
  const std::string png = (dir / "c.png").string();
  ASSERT_TRUE(write_png(png, f.color.cview()).ok());
  const std::string bytes = test::read_bytes(png);
  for (std::size_t cut : {std::size_t(10), std::size_t(40), bytes.size() / 2, bytes.size() - 13}) {
    const std::string t = (dir / ("t" + std::to_string(cut) + ".png")).string();
    test::write_bytes(t, bytes.substr(0, cut));
    auto s = read_color_image(t, c);
    ASSERT_FALSE(s.ok()) << "cut at " << cut;
    EXPECT_NE(s.error().message.find(t), std::string::npos) << s.error().message;
  }
  const std::string txt = (dir / "x.png").string();
  test::write_bytes(txt, "hello, not an image");
  EXPECT_ERROR_WITH(read_color_image(txt, c), ErrorCode::kUnsupported, txt, "unknown image format");
  Image<uint16_t> d;
  EXPECT_ERROR_WITH(read_png_u16(txt, d), ErrorCode::kCorruptData, txt, "not a PNG");
}

TEST(ImageCodec, JpegEncodeDecodeAndCorruptJpeg) {
  Frame f = test::make_frame(64, 48, 2);
  std::string bytes;
  ASSERT_TRUE(encode_jpeg(f.color.cview(), 95, bytes).ok());
  Image<Rgb8> c;
  ASSERT_TRUE(decode_jpeg(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), c, "test").ok());
  ASSERT_EQ(c.width(), 64);
  double err = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) err += std::abs(int(c(x, y).g) - int(f.color(x, y).g));
  EXPECT_LT(err / (64 * 48), 4.0);
  // Truncated in the entropy-coded data and in the header; garbage after the SOI marker.
  for (std::size_t cut : {bytes.size() / 2, std::size_t(30)}) {
    auto s = decode_jpeg(reinterpret_cast<const uint8_t*>(bytes.data()), cut, c, "colour of frame 7");
    ASSERT_FALSE(s.ok()) << "cut " << cut;
    EXPECT_EQ(s.error().code, ErrorCode::kCorruptData);
    EXPECT_NE(s.error().message.find("colour of frame 7"), std::string::npos);
  }
  std::string junk = bytes.substr(0, 4) + std::string(200, '\x55');
  EXPECT_ERROR_WITH(decode_jpeg(reinterpret_cast<const uint8_t*>(junk.data()), junk.size(), c, "junk"),
                    ErrorCode::kCorruptData, "junk");
  EXPECT_ERROR_WITH(encode_jpeg(f.color.cview(), 0, bytes), ErrorCode::kInvalidArgument, "quality");
}

TEST(ImageCodec, TruncatedJpegFileIsAnError) {
  const auto dir = test::scratch_dir("codec_jpgfile");
  Frame f = test::make_frame(64, 48, 2);
  std::string bytes;
  ASSERT_TRUE(encode_jpeg(f.color.cview(), 90, bytes).ok());
  const std::string path = (dir / "c.jpg").string();
  test::write_bytes(path, bytes);
  Image<Rgb8> c;
  ASSERT_TRUE(read_color_image(path, c).ok());
  test::write_bytes(path, bytes.substr(0, bytes.size() / 2));
  EXPECT_ERROR_WITH(read_color_image(path, c), ErrorCode::kCorruptData, path, "JPEG");
}

TEST(ImageCodec, PalettePngWithTransparencyReadsAsRgb) {
  // 4x3 palette PNG (red, green, blue) with a tRNS chunk, pixel (x, y) = palette[(x + y) mod 3].
  static const char kPng[] = "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x04\x00\x00\x00\x03\x08\x03\x00\x00\x00\x83\x2a\x5e\xf4\x00\x00\x00\x09\x50\x4c\x54\x45\xff\x00\x00\x00\xff\x00\x00\x00\xff\x2d\x4a\xcd\x8a\x00\x00\x00\x02\x74\x52\x4e\x53\x00\x80\x9b\x2b\x4e\x18\x00\x00\x00\x13\x49\x44\x41\x54\x78\x9c\x63\x60\x60\x64\x62\x00\x61\x46\x06\x20\x66\x02\x00\x00\x5f\x00\x0d\xf3\x4a\x36\x8a\x00\x00\x00\x00\x49\x45\x4e\x44\xae\x42\x60\x82";
  const auto dir = test::scratch_dir("codec_palette");
  const std::string path = (dir / "p.png").string();
  test::write_bytes(path, std::string(kPng, sizeof(kPng) - 1));
  Image<Rgb8> c;
  auto s = read_color_image(path, c);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(c.width(), 4);
  EXPECT_EQ(c(0, 0), (Rgb8{255, 0, 0}));
  EXPECT_EQ(c(1, 0), (Rgb8{0, 255, 0}));
  EXPECT_EQ(c(1, 1), (Rgb8{0, 0, 255}));
}

TEST(ImageCodec, ReadsDatasetFormats) {
  EF_SKIP_WITHOUT_DATASET(dir, "single-frames");
  Image<Rgb8> c;
  auto s = read_color_image((dir / "open3d_other_formats/NYU_color.ppm").string(), c);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(c.width(), 640);
  EXPECT_EQ(c.height(), 480);
  s = read_color_image((dir / "open3d_other_formats/SUN_color.jpg").string(), c);
  ASSERT_TRUE(s.ok()) << s.error().message;
  Image<uint16_t> d;
  s = read_png_u16((dir / "open3d_other_formats/TUM_depth.png").string(), d);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(d.width(), 640);
  s = read_color_image((dir / "slambook2_ch7_tum_pair/1.png").string(), c);
  ASSERT_TRUE(s.ok()) << s.error().message;
}

}  // namespace
}  // namespace ef
