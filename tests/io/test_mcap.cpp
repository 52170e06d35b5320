// MCAP field logs (issue 29): the PNG encoder against libpng's decoder, CDR messages of Foxglove's
// types, the MCAP writer against our reader (whole, and cut at every byte), and a log of frames
// replayed through the mcap: source. A third-party reader (@mcap/core) reads our logs in
// tests/app/test_cli_log.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "io/cdr.h"
#include "io/foxglove_msgs.h"
#include "io/image_codec.h"
#include "io/mcap_log.h"
#include "io/mcap_reader.h"
#include "io/mcap_source.h"
#include "io/mcap_writer.h"
#include "io/ply_writer.h"
#include "io/png_encoder.h"
#include "io_test_util.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;

const uint8_t* u8p(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }

// ---- PNG encoder ----

TEST(PngEncoder, SixteenBitGrayDecodesToTheSameSamples) {
  PngEncoder enc(64, 48, 3);
  std::mt19937 rng(5);
  for (const auto& [w, h] : {std::pair{64, 48}, std::pair{1, 1}, std::pair{13, 7}}) {
    Image<uint16_t> img(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) img(x, y) = uint16_t((x + y) % 3 == 0 ? rng() : 500 + x * 37 + y * 5);
    std::string png;
    ASSERT_TRUE(enc.encode(img.cview(), png).ok());
    Image<uint16_t> back;
    ASSERT_TRUE(decode_png_u16(u8p(png), png.size(), back, "test").ok());
    ASSERT_EQ(back.width(), w);
    ASSERT_EQ(back.height(), h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ASSERT_EQ(back(x, y), img(x, y)) << x << "," << y;
  }
}

TEST(PngEncoder, EightBitGrayAndRgbDecodeToTheSamePixels) {
  PngEncoder enc(40, 30, 3, 6);
  Frame f = test::make_frame(40, 30, 3);
  std::string png;
  ASSERT_TRUE(enc.encode(f.color.cview(), png).ok());
  Image<Rgb8> rgb;
  ASSERT_TRUE(decode_png_rgb(u8p(png), png.size(), rgb, "rgb").ok());
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      ASSERT_EQ(rgb(x, y).r, f.color(x, y).r);
      ASSERT_EQ(rgb(x, y).g, f.color(x, y).g);
      ASSERT_EQ(rgb(x, y).b, f.color(x, y).b);
    }
  ASSERT_TRUE(enc.encode(f.labels.cview(), png).ok());
  Image<uint8_t> labels;
  ASSERT_TRUE(decode_png_u8(u8p(png), png.size(), labels, "labels").ok());
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) ASSERT_EQ(labels(x, y), f.labels(x, y));
}

TEST(PngEncoder, AnImageLargerThanSizedForIsAnErrorAndTheOutputKeepsItsBuffer) {
  PngEncoder enc(16, 16, 2);
  Image<uint16_t> big(17, 16);
  big.fill(7);
  std::string png;
  auto s = enc.encode(big.cview(), png);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("larger than the encoder was sized for"), std::string::npos);
  Image<uint16_t> ok(16, 16);
  ok.fill(1000);
  ASSERT_TRUE(enc.encode(ok.cview(), png).ok());
  const char* before = png.data();
  ASSERT_TRUE(enc.encode(ok.cview(), png).ok());
  EXPECT_EQ(png.data(), before);  // the same buffer: nothing reallocated for the second image
}

TEST(PngEncoder, DecodingACutPngIsAnErrorNamingTheImage) {
  PngEncoder enc(32, 32, 2);
  Image<uint16_t> img(32, 32);
  img.fill(1234);
  std::string png;
  ASSERT_TRUE(enc.encode(img.cview(), png).ok());
  Image<uint16_t> back;
  EXPECT_ERROR_WITH(decode_png_u16(u8p(png), png.size() / 2, back, "frame 7 depth"), ErrorCode::kCorruptData,
                    "frame 7 depth");
  EXPECT_ERROR_WITH(decode_png_u16(u8p(png), 4, back, "tiny"), ErrorCode::kCorruptData, "tiny", "not a PNG");
}

// ---- CDR and Foxglove messages ----

TEST(FoxgloveMessages, CompressedImageRawImageCalibrationAndPoseRoundTrip) {
  std::string msg;
  const std::string data = "\x89PNG-bytes";
  foxglove::encode_compressed_image(1305031102175304000ull, "camera", data.data(), data.size(), "png", msg);
  // Header, then the time at offset 4 (sec, nanosec): the CDR layout.
  EXPECT_EQ(msg.substr(0, 4), std::string("\x00\x01\x00\x00", 4));
  foxglove::ImageMessage img;
  ASSERT_TRUE(foxglove::decode_compressed_image(u8p(msg), msg.size(), img, "t").ok());
  EXPECT_EQ(img.stamp_ns, 1305031102175304000ull);
  EXPECT_EQ(img.frame_id, "camera");
  EXPECT_EQ(img.format, "png");
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(img.data), img.bytes), data);

  const uint16_t px[6] = {1, 2, 3, 4, 5, 65535};
  foxglove::encode_raw_image(7, "cam", 3, 2, "16UC1", 6, px, msg);
  ASSERT_TRUE(foxglove::decode_raw_image(u8p(msg), msg.size(), img, "t").ok());
  EXPECT_EQ(img.width, 3u);
  EXPECT_EQ(img.height, 2u);
  EXPECT_EQ(img.step, 6u);
  EXPECT_EQ(img.format, "16UC1");
  ASSERT_EQ(img.bytes, 12u);
  EXPECT_EQ(std::memcmp(img.data, px, 12), 0);

  foxglove::encode_camera_calibration(9, "camera", 640, 480, 585.5, 586.25, 320.5, 240.75, msg);
  foxglove::Calibration c;
  ASSERT_TRUE(foxglove::decode_camera_calibration(u8p(msg), msg.size(), c, "t").ok());
  EXPECT_EQ(c.width, 640u);
  EXPECT_EQ(c.height, 480u);
  EXPECT_EQ(c.fx, 585.5);
  EXPECT_EQ(c.fy, 586.25);
  EXPECT_EQ(c.cx, 320.5);
  EXPECT_EQ(c.cy, 240.75);

  const SE3 T = test::make_frame(4, 4, 5).T_wc;
  foxglove::encode_pose_in_frame(11, "world", T, msg);
  foxglove::PoseMessage p;
  ASSERT_TRUE(foxglove::decode_pose_in_frame(u8p(msg), msg.size(), p, "t").ok());
  EXPECT_LT((p.T_wc.translation() - T.translation()).norm(), 1e-12);
  EXPECT_LT(std::abs(p.T_wc.rotation().dot(T.rotation())) - 1.0, 1e-12);
}

TEST(FoxgloveMessages, EveryCutOfAMessageIsAnErrorNamingAField) {
  std::string msg;
  foxglove::encode_camera_calibration(9, "camera", 640, 480, 525, 525, 319.5, 239.5, msg);
  foxglove::Calibration c;
  // The decoder reads up to k: every cut before the end of k fails, naming the field it ran into.
  for (std::size_t n = 0; n + 8 * 21 + 8 <= msg.size() - 1; ++n) {
    const Status s = foxglove::decode_camera_calibration(u8p(msg), n, c, "log.mcap: message at byte 99");
    ASSERT_FALSE(s.ok()) << n;
    EXPECT_NE(s.error().message.find("message at byte 99"), std::string::npos);
  }
}

TEST(FoxgloveMessages, SchemasListTheirNestedTypesAfterTheSeparatorLine) {
  const std::string sep = std::string(80, '=') + "\nMSG: ";
  const std::string pose = foxglove::pose_in_frame_schema().definition;
  EXPECT_NE(pose.find(sep + "geometry_msgs/Pose\n"), std::string::npos);
  EXPECT_NE(pose.find(sep + "geometry_msgs/Quaternion\n"), std::string::npos);
  EXPECT_NE(pose.find(sep + "builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"), std::string::npos);
  EXPECT_EQ(std::string(foxglove::compressed_image_schema().name), "foxglove_msgs/msg/CompressedImage");
}

// ---- MCAP writer and reader ----

// A log of `n` messages on two channels, each message's payload naming its number.
std::string write_small_log(const std::string& path, int n, double chunk_seconds = 0.05) {
  McapWriter w;
  McapWriterOptions o;
  o.chunk_seconds = chunk_seconds;
  EXPECT_TRUE(w.open(path, o).ok());
  auto s1 = w.add_schema("foxglove_msgs/msg/Log", "ros2msg", foxglove::log_schema().definition);
  auto s2 = w.add_schema("test/Bytes", "ros2msg", "uint8[] data\n");
  auto c1 = w.add_channel(*s1, "/log", "cdr");
  auto c2 = w.add_channel(*s2, "/bytes", "cdr");
  for (int i = 0; i < n; ++i) {
    const std::string payload = "message " + std::to_string(i) + std::string(i % 17, 'x');
    EXPECT_TRUE(w.write(i % 3 == 0 ? *c1 : *c2, 1000000000ull + uint64_t(i) * 10000000ull, 0, payload.data(),
                        payload.size())
                    .ok());
  }
  EXPECT_TRUE(w.close().ok());
  return test::read_bytes(path);
}

TEST(Mcap, TheReaderReadsEveryMessageOfAWholeLogInOrder) {
  const auto dir = test::scratch_dir("mcap_whole");
  const std::string path = (dir / "a.mcap").string();
  write_small_log(path, 100);
  McapReader r;
  ASSERT_TRUE(r.open(path).ok());
  EXPECT_TRUE(r.complete()) << r.warning();
  EXPECT_EQ(r.profile(), "ros2");
  ASSERT_EQ(r.schemas().size(), 2u);
  ASSERT_EQ(r.channels().size(), 2u);
  EXPECT_EQ(r.channel("/log")->messages, 34u);
  EXPECT_EQ(r.channel("/bytes")->messages, 66u);
  EXPECT_GE(r.chunks(), 15u);  // 1 s of log time in chunks of 0.05 s
  ASSERT_EQ(r.messages().size(), 100u);
  std::string buf;
  for (int i = 0; i < 100; ++i) {
    const McapMessageRef& m = r.messages()[i];
    ASSERT_TRUE(r.read(m, buf).ok());
    EXPECT_EQ(buf, "message " + std::to_string(i) + std::string(i % 17, 'x'));
    EXPECT_EQ(m.log_time, 1000000000ull + uint64_t(i) * 10000000ull);
  }
}

TEST(Mcap, ALogCutAtAnyByteReadsUpToItsLastWholeChunk) {
  const auto dir = test::scratch_dir("mcap_cut");
  const std::string bytes = write_small_log((dir / "a.mcap").string(), 40, 0.02);
  std::size_t last = 0;
  for (std::size_t n = 0; n <= bytes.size(); ++n) {
    McapReader r;
    const Status s = r.open_memory(u8p(bytes), n, "cut.mcap");
    if (n < 8) {
      ASSERT_FALSE(s.ok());
      EXPECT_NE(s.error().message.find("not an MCAP file"), std::string::npos);
      continue;
    }
    ASSERT_TRUE(s.ok()) << n << ": " << s.error().message;
    // Never fewer messages than a shorter cut, each one whole and in order.
    ASSERT_GE(r.messages().size(), last) << n;
    last = r.messages().size();
    std::string buf;
    for (std::size_t i = 0; i < r.messages().size(); ++i) {
      ASSERT_TRUE(r.read(r.messages()[i], buf).ok());
      ASSERT_EQ(buf, "message " + std::to_string(i) + std::string(i % 17, 'x')) << n;
    }
    if (!r.complete()) {
      EXPECT_NE(r.warning().find("cut.mcap: the log ends at byte"), std::string::npos);
    }
  }
  EXPECT_EQ(last, 40u);
}

TEST(Mcap, AChunkWhoseBytesChangedEndsTheReadingThereWithAWarning) {
  const auto dir = test::scratch_dir("mcap_crc");
  std::string bytes = write_small_log((dir / "a.mcap").string(), 40, 0.02);
  McapReader whole;
  ASSERT_TRUE(whole.open_memory(u8p(bytes), bytes.size(), "a.mcap").ok());
  // Flip a byte inside the payload of message 20.
  const McapMessageRef m = whole.messages()[20];
  bytes[m.offset + 3] ^= 0x40;
  McapReader r;
  ASSERT_TRUE(r.open_memory(u8p(bytes), bytes.size(), "a.mcap").ok());
  EXPECT_FALSE(r.complete());
  EXPECT_NE(r.warning().find("CRC"), std::string::npos) << r.warning();
  EXPECT_LE(r.messages().size(), 20u);
  EXPECT_GT(r.messages().size(), 0u);
}

TEST(Mcap, GarbageAndForeignChunksAreErrorsNamingTheFile) {
  const std::string junk = "this is not an mcap file at all";
  McapReader r;
  EXPECT_ERROR_WITH(r.open_memory(u8p(junk), junk.size(), "junk.mcap"), ErrorCode::kCorruptData, "junk.mcap",
                    "not an MCAP file");
  McapReader missing;
  EXPECT_ERROR_WITH(missing.open("/nonexistent/x.mcap"), ErrorCode::kNotFound, "/nonexistent/x.mcap");
}

TEST(Mcap, AStreamedMessageIsAChunkOfItsOwnBetweenTheOthers) {
  const auto dir = test::scratch_dir("mcap_streamed");
  const std::string path = (dir / "a.mcap").string();
  std::string big(100000, '\0');
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = char(i * 7 + 3);
  {
    McapWriter w;
    ASSERT_TRUE(w.open(path).ok());
    auto sc = w.add_schema("test/Bytes", "ros2msg", "uint8[] data\n");
    auto ch = w.add_channel(*sc, "/a", "cdr");
    ASSERT_TRUE(w.write(*ch, 10, 10, "one", 3).ok());
    ASSERT_TRUE(w.write_streamed(*ch, 20, big.size(), [&](const McapWriter::Put& put) -> Status {
                   for (std::size_t at = 0; at < big.size(); at += 4096)
                     EF_RETURN_IF_ERROR(put(big.data() + at, std::min<std::size_t>(4096, big.size() - at)));
                   return Status::success();
                 }).ok());
    ASSERT_TRUE(w.write(*ch, 30, 30, "three", 5).ok());
    // A producer that gives fewer bytes than it announced is an error.
    auto short_write = w.write_streamed(*ch, 40, 10, [](const McapWriter::Put& put) { return put("abc", 3); });
    EXPECT_FALSE(short_write.ok());
  }
  McapReader r;
  ASSERT_TRUE(r.open(path).ok());
  ASSERT_GE(r.messages().size(), 3u);
  std::string buf;
  ASSERT_TRUE(r.read(r.messages()[0], buf).ok());
  EXPECT_EQ(buf, "one");
  ASSERT_TRUE(r.read(r.messages()[1], buf).ok());
  EXPECT_TRUE(buf == big);
  ASSERT_TRUE(r.read(r.messages()[2], buf).ok());
  EXPECT_EQ(buf, "three");
}

TEST(McapLog, TheMapIsAPointCloudOfEverySurfelWithItsColourAndClass) {
  const auto dir = test::scratch_dir("mcap_map");
  const std::string path = (dir / "a.mcap").string();
  SurfelCloud cloud;
  const int n = 10000;  // more than one piece of the stream
  for (int i = 0; i < n; ++i) {
    cloud.x.push_back(0.001f * i);
    cloud.y.push_back(-0.5f * i);
    cloud.z.push_back(1.0f + i);
    for (auto* v : {&cloud.nx, &cloud.ny, &cloud.nz, &cloud.radius, &cloud.confidence, &cloud.class_prob}) v->push_back(0);
    cloud.red.push_back(uint8_t(i));
    cloud.green.push_back(uint8_t(i >> 8));
    cloud.blue.push_back(7);
    cloud.class_id.push_back(uint8_t(i % 14));
  }
  McapLogOptions o;
  o.color = "none";
  {
    McapFrameLog log;
    ASSERT_TRUE(log.open(path, o, 16, 12, Intrinsics{20, 20, 7.5f, 5.5f, 16, 12}).ok());
    ASSERT_TRUE(log.log_map(2.5, cloud.view()).ok());
    ASSERT_TRUE(log.close().ok());
  }
  McapReader r;
  ASSERT_TRUE(r.open(path).ok());
  const McapChannel* map = r.channel("/edgefusion/map");
  ASSERT_NE(map, nullptr);
  EXPECT_EQ(r.schema(map->schema_id)->name, "foxglove_msgs/msg/PointCloud");
  ASSERT_EQ(map->messages, 1u);
  std::string msg;
  ASSERT_TRUE(r.read(r.messages()[0], msg).ok());
  // The points are the message's last n * 17 bytes, after the data's length.
  ASSERT_GT(msg.size(), std::size_t(n) * 17 + 4);
  const std::size_t data = msg.size() - std::size_t(n) * 17;
  uint32_t len = 0;
  std::memcpy(&len, msg.data() + data - 4, 4);
  EXPECT_EQ(len, uint32_t(n) * 17);
  for (int i : {0, 4095, 4096, n - 1}) {
    const char* p = msg.data() + data + std::size_t(i) * 17;
    float xyz[3];
    std::memcpy(xyz, p, 12);
    EXPECT_EQ(xyz[0], cloud.x[i]);
    EXPECT_EQ(xyz[2], cloud.z[i]);
    EXPECT_EQ(uint8_t(p[12]), cloud.red[i]);
    EXPECT_EQ(uint8_t(p[13]), cloud.green[i]);
    EXPECT_EQ(uint8_t(p[15]), 255);
    EXPECT_EQ(uint8_t(p[16]), cloud.class_id[i]);
  }
}

// ---- A log of frames, replayed ----

struct LogCase {
  const char* depth;
  const char* color;
};

TEST(McapLog, FramesReplayThroughTheMcapSourceWithTheirDepthColourTimesAndPoses) {
  const auto dir = test::scratch_dir("mcap_frames");
  for (const LogCase lc : {LogCase{"png", "png"}, LogCase{"raw", "raw"}, LogCase{"png", "jpeg"}, LogCase{"png", "none"}}) {
    SCOPED_TRACE(std::string(lc.depth) + " depth, " + lc.color + " colour");
    const std::string path = (dir / (std::string(lc.depth) + "-" + lc.color + ".mcap")).string();
    McapLogOptions o;
    o.depth = lc.depth;
    o.color = lc.color;
    o.chunk_seconds = 0.05;
    const Intrinsics K{520.5f, 521.25f, 31.5f, 23.75f, 64, 48};
    std::vector<Frame> frames;
    {
      McapFrameLog log;
      ASSERT_TRUE(log.open(path, o, 64, 48, K).ok());
      auto enc = log.make_encoder();
      for (int i = 0; i < 6; ++i) {
        frames.push_back(test::make_frame(64, 48, i, false));
        frames.back().index = i;
        ASSERT_TRUE(log.log_frame(frames.back(), *enc).ok());
        ASSERT_TRUE(log.log_pose(frames.back().timestamp, frames.back().T_wc, *enc).ok());
      }
      ASSERT_TRUE(log.log_text(frames.back().timestamp, foxglove::LogLevel::kInfo, "done", *enc).ok());
      EXPECT_EQ(log.frames(), 6u);
      ASSERT_TRUE(log.close().ok());
    }
    auto uri = parse_source_uri("mcap:" + path);
    ASSERT_TRUE(uri.ok());
    auto src = open_mcap(*uri);
    ASSERT_TRUE(src.ok()) << src.error().message;
    const SourceInfo& info = (*src)->info();
    EXPECT_EQ(info.frame_count, 6);
    EXPECT_EQ(info.intrinsics.fx, K.fx);
    EXPECT_EQ(info.intrinsics.cy, K.cy);
    EXPECT_EQ(info.intrinsics.width, 64);
    EXPECT_EQ(info.has_color, std::string(lc.color) != "none");
    EXPECT_TRUE(info.has_pose);
    EXPECT_NEAR(info.nominal_fps, 1 / 0.0333, 0.01);
    Frame f;
    for (int i = 0; i < 6; ++i) {
      auto got = (*src)->next(f);
      ASSERT_TRUE(got.ok()) << got.error().message;
      ASSERT_TRUE(*got);
      const Frame& e = frames[i];
      EXPECT_NEAR(f.timestamp, e.timestamp, 1e-6);
      EXPECT_EQ(f.index, i);
      ASSERT_TRUE(f.has_pose);
      EXPECT_LT((f.T_wc.translation() - e.T_wc.translation()).norm(), 1e-12);
      for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x) ASSERT_EQ(f.depth(x, y), e.depth(x, y)) << x << "," << y;  // lossless
      if (std::string(lc.color) == "none") {
        EXPECT_TRUE(f.color.empty());
      } else if (std::string(lc.color) == "jpeg") {
        double err = 0;
        for (int y = 0; y < 48; ++y)
          for (int x = 0; x < 64; ++x) err += std::abs(int(f.color(x, y).g) - int(e.color(x, y).g));
        EXPECT_LT(err / (64 * 48), 4.0);  // lossy, but the same picture
      } else {
        for (int y = 0; y < 48; ++y)
          for (int x = 0; x < 64; ++x) ASSERT_EQ(f.color(x, y).b, e.color(x, y).b);
      }
    }
    auto end = (*src)->next(f);
    ASSERT_TRUE(end.ok());
    EXPECT_FALSE(*end);
  }
}

TEST(McapLog, ColourEveryNthFrameLeavesTheOthersBlackAndSkipIsFree) {
  const auto dir = test::scratch_dir("mcap_every");
  const std::string path = (dir / "a.mcap").string();
  McapLogOptions o;
  o.color = "png";
  o.color_every = 3;
  {
    McapFrameLog log;
    ASSERT_TRUE(log.open(path, o, 16, 12, Intrinsics{20, 20, 7.5f, 5.5f, 16, 12}).ok());
    auto enc = log.make_encoder();
    for (int i = 0; i < 7; ++i) {
      Frame f = test::make_frame(16, 12, i + 1, false);
      f.index = i;
      f.has_pose = false;
      ASSERT_TRUE(log.log_frame(f, *enc).ok());
    }
    ASSERT_TRUE(log.close().ok());
  }
  auto src = open_mcap(*parse_source_uri("mcap:" + path));
  ASSERT_TRUE(src.ok()) << src.error().message;
  EXPECT_FALSE((*src)->info().has_pose);
  Frame f;
  auto skipped = (*src)->skip(3, f);
  ASSERT_TRUE(skipped.ok());
  EXPECT_EQ(*skipped, 3);
  ASSERT_TRUE(*(*src)->next(f));  // frame 3: has colour
  EXPECT_EQ(f.index, 3);
  EXPECT_NE(f.color(5, 5).r + f.color(5, 5).g + f.color(5, 5).b, 0);
  ASSERT_TRUE(*(*src)->next(f));  // frame 4: none, black
  EXPECT_EQ(f.color(5, 5).r + f.color(5, 5).g + f.color(5, 5).b, 0);
  EXPECT_EQ(*(*src)->skip(10, f), 2);
}

TEST(McapLog, ACutLogReplaysItsWholeChunksWithAWarningAndAnEmptyOneIsAnError) {
  const auto dir = test::scratch_dir("mcap_cutlog");
  const std::string path = (dir / "a.mcap").string();
  McapLogOptions o;
  o.color = "none";
  o.chunk_seconds = 0.01;  // a chunk per frame (frames are 0.0333 s apart)
  {
    McapFrameLog log;
    ASSERT_TRUE(log.open(path, o, 16, 12, Intrinsics{20, 20, 7.5f, 5.5f, 16, 12}).ok());
    auto enc = log.make_encoder();
    for (int i = 0; i < 10; ++i) {
      Frame f = test::make_frame(16, 12, i, false);
      f.has_pose = false;  // the log's messages: the calibration, then one depth image per frame
      ASSERT_TRUE(log.log_frame(f, *enc).ok());
    }
    ASSERT_TRUE(log.close().ok());
  }
  const std::string bytes = test::read_bytes(path);
  McapReader whole;
  ASSERT_TRUE(whole.open(path).ok());
  // Cut in the middle of frame 6's depth message.
  const McapMessageRef& m6 = whole.messages()[1 + 6];
  const std::string cut_path = (dir / "cut.mcap").string();
  test::write_bytes(cut_path, bytes.substr(0, m6.offset + 10));
  auto src = open_mcap(*parse_source_uri("mcap:" + cut_path));
  ASSERT_TRUE(src.ok()) << src.error().message;
  EXPECT_EQ((*src)->info().frame_count, 6);
  EXPECT_NE((*src)->info().warning.find("left out"), std::string::npos) << (*src)->info().warning;
  // Cut before the first frame: the calibration alone is not a recording.
  test::write_bytes(cut_path, bytes.substr(0, whole.messages()[1].offset - 30));
  EXPECT_ERROR_WITH(open_mcap(*parse_source_uri("mcap:" + cut_path)), ErrorCode::kCorruptData, "cut.mcap");
}

TEST(McapLog, ALogWithoutTheDepthTopicNamesTheTopicsItHas) {
  const auto dir = test::scratch_dir("mcap_topics");
  const std::string path = (dir / "a.mcap").string();
  write_small_log(path, 5);
  EXPECT_ERROR_WITH(open_mcap(*parse_source_uri("mcap:" + path)), ErrorCode::kCorruptData, "/camera/depth",
                    "/log", "/bytes");
  EXPECT_ERROR_WITH(open_mcap(*parse_source_uri("mcap:" + path + "?bad=1")), ErrorCode::kInvalidArgument, "bad");
}

TEST(McapLog, AWrongSizeFrameAndBadOptionsAreErrors) {
  const auto dir = test::scratch_dir("mcap_bad");
  McapFrameLog log;
  McapLogOptions o;
  o.color = "gif";
  EXPECT_ERROR_WITH(log.open((dir / "a.mcap").string(), o, 16, 12, Intrinsics{20, 20, 7.5f, 5.5f, 16, 12}),
                    ErrorCode::kInvalidArgument, "log.color", "gif");
  o.color = "jpeg";
  ASSERT_TRUE(log.open((dir / "a.mcap").string(), o, 16, 12, Intrinsics{20, 20, 7.5f, 5.5f, 16, 12}).ok());
  auto enc = log.make_encoder();
  EXPECT_ERROR_WITH(log.log_frame(test::make_frame(8, 6, 1, false), *enc), ErrorCode::kInvalidArgument, "8x6", "16x12");
  ASSERT_TRUE(log.close().ok());
}

}  // namespace
}  // namespace ef
