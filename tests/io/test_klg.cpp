#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include <zlib.h>

#include "io/image_codec.h"
#include "io/klg_format.h"
#include "io/sevenscenes_source.h"
#include "io_test_util.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;

void put32(std::string& s, int32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(char(uint32_t(v) >> (8 * i)));
}
void put64(std::string& s, int64_t v) {
  for (int i = 0; i < 8; ++i) s.push_back(char(uint64_t(v) >> (8 * i)));
}
// One frame record: header then payloads.
std::string frame_record(int64_t t_us, const std::string& depth, const std::string& color) {
  std::string s;
  put64(s, t_us);
  put32(s, int32_t(depth.size()));
  put32(s, int32_t(color.size()));
  return s + depth + color;
}
std::string raw_depth(int w, int h, uint16_t mm) {
  std::string s;
  for (int i = 0; i < w * h; ++i) {
    s.push_back(char(mm & 0xFF));
    s.push_back(char(mm >> 8));
  }
  return s;
}
std::string with_count(int32_t n, const std::string& body) {
  std::string s;
  put32(s, n);
  return s + body;
}

Result<std::unique_ptr<FrameSource>> open_path(const std::string& path, const std::string& query = "") {
  auto uri = parse_source_uri("klg:" + path + query);
  if (!uri.ok()) return uri.take_error();
  return open_klg(*uri);
}

// Writes `bytes` as a .klg file and opens it at 8x6.
Result<std::unique_ptr<FrameSource>> open_bytes(const std::string& name, const std::string& bytes,
                                                std::string* path_out = nullptr, const std::string& size = "8x6") {
  const auto dir = test::scratch_dir("klg_bad");
  const std::string path = (dir / name).string();
  test::write_bytes(path, bytes);
  if (path_out) *path_out = path;
  return open_path(path, "?size=" + size);
}

TEST(KlgReader, GoodSyntheticLogRawAndCompressed) {
  std::string comp(compressBound(8 * 6 * 2), '\0');
  const std::string raw = raw_depth(8, 6, 1234);
  uLongf len = uLongf(comp.size());
  ASSERT_EQ(compress2(reinterpret_cast<Bytef*>(&comp[0]), &len, reinterpret_cast<const Bytef*>(raw.data()),
                      uLong(raw.size()), 9),
            Z_OK);
  comp.resize(len);
  const std::string bytes = with_count(2, frame_record(1000000, raw, std::string(8 * 6 * 3, '\x10')) +
                                              frame_record(1033333, comp, ""));
  std::string path;
  auto src = open_bytes("good.klg", bytes, &path);
  ASSERT_TRUE(src.ok()) << src.error().message;
  EXPECT_EQ((*src)->info().frame_count, 2);
  EXPECT_TRUE((*src)->info().has_color);
  EXPECT_FLOAT_EQ((*src)->info().intrinsics.fx, 525.f * 8 / 640);
  // A .klg holds no intrinsics: the default is assumed, and said (issue 33, rough edge 2).
  EXPECT_TRUE((*src)->info().intrinsics_assumed);
  EXPECT_NE((*src)->info().intrinsics_from.find("a .klg holds none"), std::string::npos);
  auto given = open_path(path, "?size=8x6&fx=6&fy=6&cx=4&cy=3");
  ASSERT_TRUE(given.ok());
  EXPECT_FALSE((*given)->info().intrinsics_assumed);
  EXPECT_EQ((*given)->info().intrinsics_from, "the URI's fx, fy, cx, cy");
  EXPECT_FLOAT_EQ((*given)->info().intrinsics.fx, 6.0f);
  auto part = open_path(path, "?size=8x6&fx=6");
  ASSERT_TRUE(part.ok());
  EXPECT_TRUE((*part)->info().intrinsics_assumed);  // cx, cy still the default's
  EXPECT_NE((*part)->info().intrinsics_from.find(", the URI's fx"), std::string::npos);
  Frame f;
  ASSERT_TRUE(*(*src)->next(f));
  EXPECT_FLOAT_EQ(f.depth(3, 3), 1.234f);
  EXPECT_EQ(f.color(1, 1), (Rgb8{16, 16, 16}));
  EXPECT_DOUBLE_EQ(f.timestamp, 1.0);
  ASSERT_TRUE(*(*src)->next(f));
  EXPECT_FLOAT_EQ(f.depth(7, 5), 1.234f);
  EXPECT_EQ(f.color(1, 1), (Rgb8{0, 0, 0}));  // no colour in a log that has colour: black
  EXPECT_FALSE(*(*src)->next(f));
}

TEST(KlgReader, MissingFile) {
  const auto dir = test::scratch_dir("klg_missing");
  const std::string path = (dir / "none.klg").string();
  EXPECT_ERROR_WITH(open_path(path), ErrorCode::kNotFound, path);
}

TEST(KlgReader, TruncatedInFileHeader) {
  std::string path;
  EXPECT_ERROR_WITH(open_bytes("t0.klg", std::string("\x01\x00", 2), &path), ErrorCode::kCorruptData, path,
                    "at byte 0", "truncated");
}

// A recording cut while written: its whole frames are read, and the warning says what was left.
TEST(KlgReader, CutInAFrameHeaderReadsTheWholeFramesWithAWarning) {
  const std::string f0 = frame_record(0, raw_depth(8, 6, 1000), "");
  std::string path;
  const std::string bytes = with_count(2, f0 + frame_record(1, raw_depth(8, 6, 1000), "").substr(0, 10));
  auto src = open_bytes("t1.klg", bytes, &path);
  ASSERT_TRUE(src.ok()) << src.error().message;
  EXPECT_EQ((*src)->info().frame_count, 1);
  EXPECT_EQ((*src)->info().warning, "klg file '" + path +
                                        "' was cut while written: its frame count says 2, 1 whole frame is read, and "
                                        "the last 10 bytes (a part frame) are left out");
  Frame f;
  ASSERT_TRUE(*(*src)->next(f));
  EXPECT_FLOAT_EQ(f.depth(2, 2), 1.0f);
  EXPECT_FALSE(*(*src)->next(f));
}

// Cut at every byte of a three-frame log written by KlgWriter: every whole frame before the cut is
// read back, with the right depth, and a warning whenever the file is not whole.
TEST(KlgReader, ALogCutAtAnyByteReadsItsWholeFrames) {
  const auto dir = test::scratch_dir("klg_cut");
  const std::string path = (dir / "whole.klg").string();
  KlgWriter w;
  ASSERT_TRUE(w.open(path, 8, 6, KlgWriteOptions{true, 0}).ok());
  std::vector<uint64_t> ends;  // the file's length after each frame: the count is right at each
  for (int i = 0; i < 3; ++i) {
    Frame f;
    f.allocate(8, 6, false);
    f.depth.fill(0.5f + 0.25f * float(i));
    f.color.fill(Rgb8{uint8_t(10 * i), 0, 0});
    f.timestamp = 1.0 + i / 30.0;
    ASSERT_TRUE(w.write(f).ok());
    ends.push_back(fs::file_size(path));
    // Killed now, the file is complete: its count already says i + 1.
    auto now = open_path(path, "?size=8x6");
    ASSERT_TRUE(now.ok()) << now.error().message;
    EXPECT_EQ((*now)->info().frame_count, i + 1);
    EXPECT_EQ((*now)->info().warning, "");
  }
  ASSERT_TRUE(w.close().ok());
  const std::string bytes = test::read_bytes(path);
  for (std::size_t cut = 4; cut < bytes.size(); ++cut) {
    const std::string cut_path = (dir / "cut.klg").string();
    test::write_bytes(cut_path, bytes.substr(0, cut));
    auto src = open_path(cut_path, "?size=8x6");
    const int whole = int(std::count_if(ends.begin(), ends.end(), [&](uint64_t e) { return e <= cut; }));
    if (whole == 0) {
      EXPECT_FALSE(src.ok()) << cut;
      continue;
    }
    ASSERT_TRUE(src.ok()) << cut << ": " << src.error().message;
    EXPECT_EQ((*src)->info().frame_count, whole) << cut;
    EXPECT_NE((*src)->info().warning.find(std::to_string(whole) + " whole frame"), std::string::npos) << cut;
    Frame f;
    for (int i = 0; i < whole; ++i) {
      ASSERT_TRUE(*(*src)->next(f)) << cut;
      EXPECT_FLOAT_EQ(f.depth(4, 3), 0.5f + 0.25f * float(i));
    }
    EXPECT_FALSE(*(*src)->next(f));
  }
}

TEST(KlgReader, TruncatedInFramePayload) {
  std::string bytes = with_count(1, frame_record(0, raw_depth(8, 6, 1000), std::string(8 * 6 * 3, 'x')));
  bytes.resize(bytes.size() - 5);
  std::string path;
  EXPECT_ERROR_WITH(open_bytes("t2.klg", bytes, &path), ErrorCode::kCorruptData, path, "frame 0", "at byte 4",
                    "truncated");
}

TEST(KlgReader, NegativeAndHugeSizeFields) {
  std::string hdr;
  put64(hdr, 0);
  put32(hdr, -5);
  put32(hdr, 0);
  std::string path;
  EXPECT_ERROR_WITH(open_bytes("neg.klg", with_count(1, hdr + std::string(100, '\0')), &path), ErrorCode::kCorruptData,
                    path, "frame 0", "depth size -5");
  hdr.clear();
  put64(hdr, 0);
  put32(hdr, 96);
  put32(hdr, 99999999);
  EXPECT_ERROR_WITH(open_bytes("huge.klg", with_count(1, hdr + std::string(100, '\0')), &path),
                    ErrorCode::kCorruptData, path, "image size 99999999", "8x6");
  EXPECT_ERROR_WITH(open_bytes("negcount.klg", with_count(-3, ""), &path), ErrorCode::kCorruptData, path,
                    "negative frame count");
  // A count far beyond the frames present: the frames present, with the warning.
  auto huge = open_bytes("hugecount.klg", with_count(2147483647, frame_record(0, raw_depth(8, 6, 1), "")), &path);
  ASSERT_TRUE(huge.ok()) << huge.error().message;
  EXPECT_EQ((*huge)->info().frame_count, 1);
  EXPECT_NE((*huge)->info().warning.find("its frame count says 2147483647, 1 whole frame is read"), std::string::npos);
}

TEST(KlgReader, TrailingBytesAndDecreasingTimestamps) {
  const std::string f0 = frame_record(100, raw_depth(8, 6, 1), "");
  std::string path;
  // Fewer bytes than a frame header after the counted frames: a part frame, left out with a warning.
  auto trail = open_bytes("trail.klg", with_count(1, f0 + "junk"), &path);
  ASSERT_TRUE(trail.ok()) << trail.error().message;
  EXPECT_NE((*trail)->info().warning.find("the last 4 bytes (a part frame) are left out"), std::string::npos);
  // A header's worth of bytes that is not a frame: an error, as the count or the size is wrong.
  EXPECT_ERROR_WITH(open_bytes("junk.klg", with_count(1, f0 + std::string(20, '\xff')), &path),
                    ErrorCode::kCorruptData, path, "20 bytes after the last of 1 frames that are not frames");
  // A count never written (0) over whole frames: the frames, with the warning.
  auto zero = open_bytes("zero.klg", with_count(0, f0 + frame_record(200, raw_depth(8, 6, 1), "")), &path);
  ASSERT_TRUE(zero.ok()) << zero.error().message;
  EXPECT_EQ((*zero)->info().frame_count, 2);
  EXPECT_NE((*zero)->info().warning.find("its frame count says 0, 2 whole frames are read"), std::string::npos);
  EXPECT_ERROR_WITH(open_bytes("back.klg", with_count(2, f0 + frame_record(50, raw_depth(8, 6, 1), "")), &path),
                    ErrorCode::kCorruptData, path, "frame 1", "before the previous");
}

TEST(KlgReader, CorruptZlibStream) {
  const std::string bytes = with_count(1, frame_record(0, std::string("\x78\x01garbage-not-deflate"), ""));
  std::string path;
  auto src = open_bytes("zlib.klg", bytes, &path);
  ASSERT_TRUE(src.ok()) << src.error().message;
  Frame f;
  EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, path, "frame 0", "at byte 4", "compressed depth");
}

TEST(KlgReader, CorruptJpeg) {
  // 64x48: big enough that a JPEG is smaller than raw RGB.
  Frame good = test::make_frame(64, 48, 1);
  std::string jpg;
  ASSERT_TRUE(encode_jpeg(good.color.cview(), 90, jpg).ok());
  const std::string depth = raw_depth(64, 48, 1);
  std::string path;
  {  // Truncated JPEG.
    auto src = open_bytes("jpg1.klg", with_count(1, frame_record(0, depth, jpg.substr(0, jpg.size() / 2))), &path,
                          "64x48");
    ASSERT_TRUE(src.ok()) << src.error().message;
    Frame f;
    EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, path, "frame 0", "JPEG");
  }
  {  // Entropy-coded data overwritten with garbage.
    std::string bad = jpg;
    for (std::size_t i = bad.size() / 2; i < bad.size() - 2; ++i) bad[i] = char(0xFF);
    auto src = open_bytes("jpg4.klg", with_count(1, frame_record(0, depth, bad)), &path, "64x48");
    ASSERT_TRUE(src.ok()) << src.error().message;
    Frame f;
    EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, path, "frame 0", "JPEG");
  }
  {  // Not a JPEG at all.
    auto src = open_bytes("jpg2.klg", with_count(1, frame_record(0, depth, "hello")), &path, "64x48");
    ASSERT_TRUE(src.ok()) << src.error().message;
    Frame f;
    EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, path, "frame 0", "not a JPEG");
  }
  {  // A JPEG of another size.
    Frame other = test::make_frame(32, 48, 1);
    ASSERT_TRUE(encode_jpeg(other.color.cview(), 90, jpg).ok());
    auto src = open_bytes("jpg3.klg", with_count(1, frame_record(0, depth, jpg)), &path, "64x48");
    ASSERT_TRUE(src.ok()) << src.error().message;
    Frame f;
    EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, path, "32x48", "expected 64x48");
  }
}

TEST(KlgReader, WrongSizeForRawLog) {
  const auto dir = test::scratch_dir("klg_wrongsize");
  const std::string path = (dir / "raw.klg").string();
  {
    KlgWriter w;
    ASSERT_TRUE(w.open(path, 16, 12, KlgWriteOptions{false, 0}).ok());
    ASSERT_TRUE(w.write(test::make_frame(16, 12, 0)).ok());
    ASSERT_TRUE(w.close().ok());
  }
  EXPECT_TRUE(open_path(path, "?size=16x12").ok());
  // Smaller: the raw depth is larger than the size allows.
  EXPECT_ERROR_WITH(open_path(path, "?size=8x6"), ErrorCode::kCorruptData, path, "frame 0", "depth size 384",
                    "size=WxH");
  // Larger: the raw depth is taken for a zlib stream, which fails when read.
  auto src = open_path(path, "?size=32x24");
  if (src.ok()) {
    Frame f;
    EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, path, "frame 0", "size=WxH");
  } else {
    EXPECT_NE(src.error().message.find(path), std::string::npos);
  }
  EXPECT_ERROR_WITH(open_path(path, "?size=16by12"), ErrorCode::kInvalidArgument, "size=16by12");
  EXPECT_ERROR_WITH(open_path(path, "?sise=16x12"), ErrorCode::kInvalidArgument, "'sise'", "'klg'");
}

TEST(KlgReader, InMemoryEntryPoint) {
  const std::string bytes = with_count(1, frame_record(7, raw_depth(4, 2, 0), ""));
  auto src = open_klg_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), 4, 2, "mem");
  ASSERT_TRUE(src.ok()) << src.error().message;
  EXPECT_FALSE((*src)->info().has_color);
  Frame f;
  ASSERT_TRUE(*(*src)->next(f));
  EXPECT_TRUE(f.color.empty());
  EXPECT_EQ(f.depth(1, 1), 0.0f);
}

TEST(KlgRoundTrip, SyntheticFramesAllModes) {
  const auto dir = test::scratch_dir("klg_rt");
  for (int mode = 0; mode < 4; ++mode) {
    const KlgWriteOptions opt{mode % 2 == 0, mode < 2 ? 0 : 95};
    const std::string path = (dir / ("rt" + std::to_string(mode) + ".klg")).string();
    KlgWriter w;
    ASSERT_TRUE(w.open(path, 32, 24, opt).ok());
    for (int i = 0; i < 5; ++i) ASSERT_TRUE(w.write(test::make_frame(32, 24, i)).ok());
    ASSERT_TRUE(w.close().ok());
    auto src = open_path(path, "?size=32x24");
    ASSERT_TRUE(src.ok()) << src.error().message;
    EXPECT_EQ((*src)->info().frame_count, 5);
    Frame f;
    for (int i = 0; i < 5; ++i) {
      auto r = (*src)->next(f);
      ASSERT_TRUE(r.ok()) << r.error().message;
      const Frame ref = test::make_frame(32, 24, i);
      EXPECT_NEAR(f.timestamp, ref.timestamp, 1e-6);
      double cerr = 0;
      for (std::size_t k = 0; k < ref.depth.size(); ++k) {
        ASSERT_EQ(f.depth.data()[k], ref.depth.data()[k]) << "mode " << mode << " frame " << i;
        cerr += std::abs(int(f.color.data()[k].r) - int(ref.color.data()[k].r));
      }
      if (opt.jpeg_quality == 0) EXPECT_EQ(cerr, 0);
      else EXPECT_LT(cerr / double(ref.depth.size()), 6.0);
    }
  }
}

// The first 50 frames of 7-Scenes to .klg and back: depth identical, colour within JPEG tolerance.
TEST(KlgRoundTrip, SevenScenesFirst50FramesLosslessDepth) {
  EF_SKIP_WITHOUT_DATASET(data, "7scenes-redkitchen");
  const auto dir = test::scratch_dir("klg_7s");
  SourceUri uri;
  uri.scheme = "7scenes";
  uri.path = data.string();
  constexpr int kFrames = 50;
  std::vector<Frame> ref(kFrames);
  {
    auto src = open_7scenes(uri);
    ASSERT_TRUE(src.ok()) << src.error().message;
    for (auto& f : ref) ASSERT_TRUE(*(*src)->next(f));
  }
  for (int mode = 0; mode < 2; ++mode) {
    const bool raw = mode == 1;
    const std::string path = (dir / (raw ? "raw.klg" : "comp.klg")).string();
    KlgWriter w;
    ASSERT_TRUE(w.open(path, 640, 480, KlgWriteOptions{!raw, raw ? 0 : 90}).ok());
    for (const auto& f : ref) ASSERT_TRUE(w.write(f).ok());
    ASSERT_TRUE(w.close().ok());
    auto src = open_path(path);
    ASSERT_TRUE(src.ok()) << src.error().message;
    ASSERT_EQ((*src)->info().frame_count, kFrames);
    Frame f;
    f.allocate(640, 480, false);
    const float* depth_ptr = f.depth.data();
    for (int i = 0; i < kFrames; ++i) {
      auto r = (*src)->next(f);
      ASSERT_TRUE(r.ok()) << r.error().message;
      ASSERT_TRUE(*r);
      EXPECT_EQ(f.depth.data(), depth_ptr);
      EXPECT_EQ(std::memcmp(f.depth.data(), ref[std::size_t(i)].depth.data(), f.depth.size() * sizeof(float)), 0)
          << "frame " << i;
      EXPECT_NEAR(f.timestamp, i / 30.0, 1e-6);
      double err = 0;
      for (std::size_t k = 0; k < f.color.size(); ++k)
        err += std::abs(int(f.color.data()[k].g) - int(ref[std::size_t(i)].color.data()[k].g));
      if (raw) EXPECT_EQ(err, 0);
      else EXPECT_LT(err / double(f.color.size()), 3.0);
    }
    EXPECT_FALSE(*(*src)->next(f));
  }
}

}  // namespace
}  // namespace ef
