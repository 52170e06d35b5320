#include <gtest/gtest.h>

#include <filesystem>

#include "io/image_codec.h"
#include "io/tum_source.h"
#include "io/tum_writer.h"
#include "io_test_util.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;

Result<std::unique_ptr<FrameSource>> open_tum_dir(const fs::path& dir, const std::string& query = "") {
  SourceUri uri;
  uri.scheme = "tum";
  uri.path = dir.string();
  auto parsed = parse_source_uri("tum:" + dir.string() + query);
  if (!parsed.ok()) return parsed.take_error();
  return open_tum(*parsed);
}

// Writes `n` synthetic frames as a TUM folder.
void write_tum_folder(const fs::path& dir, int n, int w = 32, int h = 24, bool labels = true) {
  TumWriter writer;
  Intrinsics k{30.f, -31.f, 15.5f, 11.5f, w, h};
  ASSERT_TRUE(writer.open(dir.string(), k).ok());
  for (int i = 0; i < n; ++i) {
    Status s = writer.write(test::make_frame(w, h, i, labels));
    ASSERT_TRUE(s.ok()) << s.error().message;
  }
  ASSERT_TRUE(writer.close().ok());
}

TEST(TumLists, ParsesCommentsAndFields) {
  auto r = parse_tum_list("# color images\n#  timestamp filename\n1.5 rgb/a.png\r\n\n  2.25\trgb/b.png\n", "rgb.txt");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[1].timestamp, 2.25);
  EXPECT_EQ((*r)[1].path, "rgb/b.png");
}

TEST(TumLists, GarbageTimestampNamesFileAndLine) {
  EXPECT_ERROR_WITH(parse_tum_list("# x\n1.0 a.png\n1.2.3 b.png\n", "list 'd/rgb.txt'"), ErrorCode::kCorruptData,
                    "d/rgb.txt", "line 3", "'1.2.3'");
  EXPECT_ERROR_WITH(parse_tum_list("nan a.png\n", "rgb.txt"), ErrorCode::kCorruptData, "line 1");
}

TEST(TumLists, NonMonotonicTimestampsNameFileAndLine) {
  EXPECT_ERROR_WITH(parse_tum_list("1.0 a.png\n2.0 b.png\n1.5 c.png\n", "depth.txt"), ErrorCode::kCorruptData,
                    "depth.txt", "line 3", "must increase");
  EXPECT_ERROR_WITH(parse_tum_groundtruth("1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", "gt.txt"), ErrorCode::kCorruptData,
                    "gt.txt", "line 2");
}

TEST(TumLists, MissingFieldsAndBadQuaternions) {
  EXPECT_ERROR_WITH(parse_tum_list("1.0\n", "rgb.txt"), ErrorCode::kCorruptData, "line 1", "1 fields");
  EXPECT_ERROR_WITH(parse_tum_groundtruth("1 0 0 0 0 0 1\n", "gt.txt"), ErrorCode::kCorruptData, "gt.txt", "7 fields");
  EXPECT_ERROR_WITH(parse_tum_groundtruth("1 0 0 0 0 0 0 0\n", "gt.txt"), ErrorCode::kCorruptData, "quaternion");
  EXPECT_ERROR_WITH(parse_tum_groundtruth("1 0 0 x 0 0 0 1\n", "gt.txt"), ErrorCode::kCorruptData, "field 4");
  EXPECT_ERROR_WITH(parse_tum_intrinsics("1 2 3\n", "intr.txt"), ErrorCode::kCorruptData, "intr.txt");
}

TEST(TumAssociate, GreedyOneToOneWithinMaxDifference) {
  // rgb at 0, 0.033, 0.066; depth at 0.01, 0.02, 0.07, 0.5.
  const auto m = associate_timestamps({0.0, 0.033, 0.066}, {0.01, 0.02, 0.07, 0.5}, 0.02);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0], std::make_pair(std::size_t(0), std::size_t(0)));  // 0.01 (dt 0.01)
  EXPECT_EQ(m[1], std::make_pair(std::size_t(1), std::size_t(1)));  // 0.02 (dt 0.013)
  EXPECT_EQ(m[2], std::make_pair(std::size_t(2), std::size_t(2)));  // 0.07
  // A depth image is not used twice: the closer rgb wins.
  const auto m2 = associate_timestamps({0.0, 0.015}, {0.012}, 0.02);
  ASSERT_EQ(m2.size(), 1u);
  EXPECT_EQ(m2[0].first, 1u);
}

TEST(TumPoses, InterpolatesAndRespectsMaxDifference) {
  std::vector<StampedPose> gt(2);
  gt[0].timestamp = 1.0;
  gt[0].T_wc = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0));
  gt[1].timestamp = 1.01;
  gt[1].T_wc = SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(1, 0, 0));
  SE3 p;
  ASSERT_TRUE(lookup_pose(gt, 1.005, 0.02, p));
  EXPECT_NEAR(p.translation().x(), 0.5, 1e-9);
  EXPECT_NEAR(p.angle(), 0.1, 1e-9);
  ASSERT_TRUE(lookup_pose(gt, 1.02, 0.02, p));  // after the last sample, within 0.02 s
  EXPECT_NEAR(p.translation().x(), 1.0, 1e-12);
  EXPECT_FALSE(lookup_pose(gt, 1.05, 0.02, p));
  EXPECT_FALSE(lookup_pose(gt, 0.9, 0.02, p));
}

TEST(TumSource, MissingFolderAndMissingLists) {
  const auto dir = test::scratch_dir("tum_missing");
  EXPECT_ERROR_WITH(open_tum_dir(dir / "nothing"), ErrorCode::kNotFound, (dir / "nothing").string());
  EXPECT_ERROR_WITH(open_tum_dir(dir), ErrorCode::kNotFound, (dir / "rgb.txt").string());
  test::write_bytes((dir / "rgb.txt").string(), "1.0 rgb/a.png\n");
  EXPECT_ERROR_WITH(open_tum_dir(dir), ErrorCode::kNotFound, (dir / "depth.txt").string());
}

TEST(TumSource, GarbageInRgbTxtNamesFileAndLine) {
  const auto dir = test::scratch_dir("tum_garbage");
  write_tum_folder(dir, 2);
  test::write_bytes((dir / "rgb.txt").string(), "# c\n1305031102.175304 rgb/f0.png\n13050311O2.2 rgb/f1.png\n");
  EXPECT_ERROR_WITH(open_tum_dir(dir), ErrorCode::kCorruptData, (dir / "rgb.txt").string(), "line 3");
}

TEST(TumSource, MissingImageFileNamesFileAndFrame) {
  const auto dir = test::scratch_dir("tum_noimage");
  write_tum_folder(dir, 3);
  fs::remove(dir / "rgb" / "f1.png");
  auto src = open_tum_dir(dir);
  ASSERT_TRUE(src.ok()) << src.error().message;
  Frame f;
  ASSERT_TRUE((*src)->next(f).ok());
  EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kNotFound, (dir / "rgb" / "f1.png").string(), "frame 1");
}

TEST(TumSource, DepthColourSizeMismatchNamesFileAndFrame) {
  const auto dir = test::scratch_dir("tum_size");
  write_tum_folder(dir, 3);
  Frame big = test::make_frame(40, 24, 9);
  ASSERT_TRUE(write_png((dir / "rgb" / "f2.png").string(), big.color.cview()).ok());
  auto src = open_tum_dir(dir);
  ASSERT_TRUE(src.ok()) << src.error().message;
  Frame f;
  ASSERT_TRUE(*(*src)->next(f));
  ASSERT_TRUE(*(*src)->next(f));
  EXPECT_ERROR_WITH((*src)->next(f), ErrorCode::kCorruptData, (dir / "rgb" / "f2.png").string(), "frame 2", "40x24",
                    "32x24");
}

TEST(TumSource, EightBitDepthIsAnError) {
  const auto dir = test::scratch_dir("tum_8bit");
  write_tum_folder(dir, 2);
  Image<uint8_t> d8(32, 24);
  ASSERT_TRUE(write_png((dir / "depth" / "f0.png").string(), d8.cview()).ok());
  EXPECT_ERROR_WITH(open_tum_dir(dir), ErrorCode::kUnsupported, (dir / "depth" / "f0.png").string(), "16-bit");
}

TEST(TumSource, UnknownQueryKeyAndBadOverride) {
  const auto dir = test::scratch_dir("tum_query");
  write_tum_folder(dir, 1);
  EXPECT_ERROR_WITH(open_tum_dir(dir, "?scale=2"), ErrorCode::kInvalidArgument, "'scale'", "'tum'");
  EXPECT_ERROR_WITH(open_tum_dir(dir, "?fx=abc"), ErrorCode::kInvalidArgument, "fx=abc");
}

TEST(TumSource, MissingLabelImageNamesFile) {
  const auto dir = test::scratch_dir("tum_nolabel");
  write_tum_folder(dir, 2);
  fs::remove(dir / "labels" / "f1.png");
  EXPECT_ERROR_WITH(open_tum_dir(dir), ErrorCode::kNotFound, (dir / "labels" / "f1.png").string(), "frame 1");
}

TEST(TumSource, WriterReaderRoundTripIsExact) {
  const auto dir = test::scratch_dir("tum_roundtrip");
  const int n = 4, w = 32, h = 24;
  write_tum_folder(dir, n, w, h);
  auto src = open_tum_dir(dir);
  ASSERT_TRUE(src.ok()) << src.error().message;
  const SourceInfo& info = (*src)->info();
  EXPECT_EQ(info.frame_count, n);
  EXPECT_TRUE(info.has_pose);
  EXPECT_TRUE(info.has_labels);
  EXPECT_EQ(info.intrinsics.width, w);
  EXPECT_FLOAT_EQ(info.intrinsics.fy, -31.f);
  EXPECT_FLOAT_EQ(info.intrinsics.cx, 15.5f);
  // From the folder's intrinsics.txt, not assumed; without it, the default, said (rough edge 2).
  EXPECT_FALSE(info.intrinsics_assumed);
  EXPECT_EQ(info.intrinsics_from, (dir / "intrinsics.txt").string());
  {
    const auto bare = test::scratch_dir("tum_roundtrip_bare");
    write_tum_folder(bare, 1, w, h);
    fs::remove(bare / "intrinsics.txt");
    auto plain = open_tum_dir(bare);
    ASSERT_TRUE(plain.ok()) << plain.error().message;
    EXPECT_TRUE((*plain)->info().intrinsics_assumed);
    EXPECT_NE((*plain)->info().intrinsics_from.find("Kinect v1"), std::string::npos);
  }
  Frame f;
  f.allocate(w, h, true);
  const Rgb8* color_ptr = f.color.data();
  const float* depth_ptr = f.depth.data();
  for (int i = 0; i < n; ++i) {
    auto r = (*src)->next(f);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(*r);
    const Frame ref = test::make_frame(w, h, i);
    EXPECT_EQ(f.color.data(), color_ptr);  // buffers reused
    EXPECT_EQ(f.depth.data(), depth_ptr);
    EXPECT_EQ(f.name, ref.name);
    EXPECT_NEAR(f.timestamp, ref.timestamp, 5e-7);
    ASSERT_TRUE(f.has_pose);
    EXPECT_NEAR((f.T_wc.translation() - ref.T_wc.translation()).norm(), 0, 1e-12);
    EXPECT_NEAR(f.T_wc.rotation().angularDistance(ref.T_wc.rotation()), 0, 1e-9);
    ASSERT_TRUE(f.has_labels);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_EQ(f.color(x, y), ref.color(x, y));
        ASSERT_NEAR(f.depth(x, y), ref.depth(x, y), 1e-4f);
        ASSERT_EQ(f.depth(x, y) == 0, ref.depth(x, y) == 0);
        ASSERT_EQ(f.labels(x, y), ref.labels(x, y));
      }
  }
  auto end = (*src)->next(f);
  ASSERT_TRUE(end.ok());
  EXPECT_FALSE(*end);
}

TEST(TumSource, ReadsIclNuimFrames) {
  EF_SKIP_WITHOUT_DATASET(dir, "iclnuim-lr-kt0-6frames");
  auto src = open_tum_dir(dir, "?fx=481.2&fy=-480");
  ASSERT_TRUE(src.ok()) << src.error().message;
  const SourceInfo& info = (*src)->info();
  EXPECT_EQ(info.frame_count, 6);
  EXPECT_FALSE(info.has_pose);
  EXPECT_FALSE(info.has_labels);
  EXPECT_FLOAT_EQ(info.intrinsics.fx, 481.2f);
  EXPECT_FLOAT_EQ(info.intrinsics.fy, -480.f);
  EXPECT_FLOAT_EQ(info.intrinsics.cx, 319.5f);
  EXPECT_EQ(info.intrinsics.width, 640);
  EXPECT_NEAR(info.nominal_fps, 30.0, 0.01);
  Frame f;
  int count = 0;
  for (;;) {
    auto r = (*src)->next(f);
    ASSERT_TRUE(r.ok()) << r.error().message;
    if (!*r) break;
    EXPECT_EQ(f.index, count);
    EXPECT_EQ(f.color.width(), 640);
    EXPECT_EQ(f.depth.height(), 480);
    EXPECT_FALSE(f.has_pose);
    float lo = 1e9f, hi = 0;
    for (std::size_t i = 0; i < f.depth.size(); ++i) {
      lo = std::min(lo, f.depth.data()[i]);
      hi = std::max(hi, f.depth.data()[i]);
    }
    EXPECT_GT(lo, 1.0f);
    EXPECT_LT(hi, 4.0f);
    ++count;
  }
  EXPECT_EQ(count, 6);
  EXPECT_EQ(f.name, "scene_00_0005_rs");
  EXPECT_NEAR(f.timestamp, 0.199998, 1e-9);
}

}  // namespace
}  // namespace ef
