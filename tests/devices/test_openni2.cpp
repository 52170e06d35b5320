// The OpenNI2 camera source, streamed from OpenNI2's software "Dummy" device, which Debian's
// libopenni2-0 ships (OpenNI2/Drivers/libDummyDevice.so.0, opened with the device URI "Dummy"): a
// 320x240 depth stream in 1 mm units and an RGB888 colour stream at 30 fps generated in memory, no
// field of view, no registration. The same source code path as a USB camera, minus USB.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <chrono>
#include <thread>

#include "camera_test_util.h"
#include "test_support.h"
#include "platform/devices/cameras.h"
#include "sources/open_source.h"

namespace ef {
namespace {

// Opens the Dummy device, or says why the test must skip (sets `skip`).
std::unique_ptr<CameraSource> open_dummy(const std::string& query, std::string& skip) {
  if (!openni2_built()) {
    skip = "built without libopenni2-dev: the OpenNI2 source is not built";
    return nullptr;
  }
  if (!test::openni2_dummy_driver_installed()) {
    skip = "OpenNI2's Dummy driver is not installed in " + test::openni2_driver_dir() + " (libopenni2-0)";
    return nullptr;
  }
  auto uri = parse_source_uri("openni2:Dummy" + query);
  EXPECT_TRUE(uri.ok());
  auto cam = open_openni2_camera(*uri);
  // Under qemu-user the driver is the arm64 one; if OpenNI2 cannot load it there, say so.
  if (test::kUnderEmulator && !cam.ok()) {
    skip = "OpenNI2's Dummy driver does not load under the emulator: " + cam.error().message;
    return nullptr;
  }
  EXPECT_TRUE(cam.ok()) << cam.error().message;
  if (!cam.ok()) return nullptr;
  return std::move(cam).value();
}

TEST(OpenNi2, StreamsTheDummyDevice) {
  std::string skip;
  auto cam = open_dummy("", skip);
  if (!skip.empty()) GTEST_SKIP() << skip;
  ASSERT_NE(cam, nullptr);
  const SourceInfo& info = cam->info();
  EXPECT_TRUE(info.live);
  EXPECT_EQ(info.frame_count, -1);
  EXPECT_TRUE(info.has_color);
  EXPECT_FALSE(info.has_pose);
  EXPECT_EQ(info.uri, "openni2:Dummy");
  // The Dummy has only 320x240; it reports no field of view, so the PrimeSense default applies.
  ASSERT_EQ(info.intrinsics.width, 320);
  ASSERT_EQ(info.intrinsics.height, 240);
  EXPECT_FLOAT_EQ(info.intrinsics.fx, 262.5f);
  EXPECT_FLOAT_EQ(info.intrinsics.fy, 262.5f);
  EXPECT_FLOAT_EQ(info.intrinsics.cx, 159.5f);
  EXPECT_FLOAT_EQ(info.intrinsics.cy, 119.5f);
  EXPECT_DOUBLE_EQ(info.nominal_fps, 30);

  Frame frame;
  double last_t = -1;
  for (int i = 0; i < 6; ++i) {
    auto r = cam->next(frame);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(*r);
    EXPECT_EQ(frame.index, i);
    ASSERT_EQ(frame.depth.width(), 320);
    ASSERT_EQ(frame.depth.height(), 240);
    ASSERT_EQ(frame.color.width(), 320);
    ASSERT_EQ(frame.color.height(), 240);
    EXPECT_GT(frame.timestamp, last_t) << "timestamps must increase (frame " << i << ")";
    last_t = frame.timestamp;
    EXPECT_FALSE(frame.name.empty());
    // Depth in metres: the Dummy's samples are whole millimetres (its pattern has 2000 = 2 m).
    float max_depth = 0;
    int valid = 0;
    for (std::size_t p = 0; p < frame.depth.size(); ++p) {
      const float d = frame.depth.data()[p];
      ASSERT_GE(d, 0.0f);
      if (d > 0) ++valid;
      max_depth = std::max(max_depth, d);
      const float mm = d * 1000.0f;
      ASSERT_NEAR(mm, std::round(mm), 1e-3f) << "depth not in 1 mm steps at " << p;
    }
    EXPECT_GT(valid, 0);
    EXPECT_LE(max_depth, 65.535f);
  }
  // The frame period is the device's: 30 fps is about 33 ms apart (device clock).
  EXPECT_GT(last_t, 0);
}

TEST(OpenNi2, BuffersAreReusedFrameToFrame) {
  std::string skip;
  auto cam = open_dummy("", skip);
  if (!skip.empty()) GTEST_SKIP() << skip;
  ASSERT_NE(cam, nullptr);
  Frame frame;
  ASSERT_TRUE(cam->next(frame).ok());
  const float* depth = frame.depth.data();
  const Rgb8* color = frame.color.data();
  ASSERT_TRUE(cam->next(frame).ok());
  EXPECT_EQ(frame.depth.data(), depth);
  EXPECT_EQ(frame.color.data(), color);
}

TEST(OpenNi2, DisconnectWhileStreamingIsCameraLost) {
  std::string skip;
  auto cam = open_dummy("?timeout_ms=500", skip);
  if (!skip.empty()) GTEST_SKIP() << skip;
  ASSERT_NE(cam, nullptr);
  Frame frame;
  ASSERT_TRUE(cam->next(frame).ok());
  // OpenNI's disconnect listener calls notify_disconnected() on OpenNI's thread; here another thread
  // does, while the capture thread is inside next().
  std::atomic<bool> stop{false};
  std::thread unplug([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    cam->notify_disconnected();
    stop = true;
  });
  Error lost{ErrorCode::kInternal, ""};
  bool got_error = false;
  for (int i = 0; i < 200 && !got_error; ++i) {
    auto r = cam->next(frame);
    if (!r.ok()) {
      lost = r.take_error();
      got_error = true;
    }
  }
  unplug.join();
  ASSERT_TRUE(got_error);
  EXPECT_EQ(lost.code, ErrorCode::kNotFound);
  EXPECT_NE(lost.message.find("openni2:Dummy"), std::string::npos) << lost.message;
  EXPECT_NE(lost.message.find(kCameraLostText), std::string::npos) << lost.message;
  EXPECT_TRUE(is_camera_lost(cam->info(), lost));
  // It stays lost.
  auto again = cam->next(frame);
  ASSERT_FALSE(again.ok());
  EXPECT_TRUE(is_camera_lost(cam->info(), again.error()));
}

TEST(OpenNi2, ThroughOpenSource) {
  std::string skip;
  auto probe = open_dummy("", skip);
  if (!skip.empty()) GTEST_SKIP() << skip;
  probe.reset();
  auto src = open_source("openni2:Dummy?size=320x240&fps=30&fx=300&cy=100");
  ASSERT_TRUE(src.ok()) << src.error().message;
  EXPECT_FLOAT_EQ((*src)->info().intrinsics.fx, 300.0f);
  EXPECT_FLOAT_EQ((*src)->info().intrinsics.cy, 100.0f);
  Frame frame;
  auto r = (*src)->next(frame);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(*r);
}

TEST(OpenNi2, Errors) {
  if (!openni2_built()) {
    auto r = open_source("openni2:Dummy");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(r.error().message.find("not built: missing package libopenni2-dev"), std::string::npos);
    GTEST_SKIP() << "built without libopenni2-dev";
  }
  // A recording that is not there.
  auto missing = open_source("openni2:/nonexistent/edgefusion-test.oni");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound) << missing.error().message;
  EXPECT_NE(missing.error().message.find("/nonexistent/edgefusion-test.oni"), std::string::npos)
      << missing.error().message;
  // Bad options, named.
  auto bad = open_source("openni2:Dummy?fps=fast");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(bad.error().message.find("fps=fast"), std::string::npos) << bad.error().message;
  auto unknown = open_source("openni2:Dummy?exposure=3");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("exposure"), std::string::npos) << unknown.error().message;
  if (!test::openni2_dummy_driver_installed()) return;
  // A mode the device does not have.
  auto size = open_source("openni2:Dummy?size=1280x1024");
  if (size.ok()) GTEST_SKIP() << "the Dummy driver here has 1280x1024 (not Debian's)";
  if (test::kUnderEmulator && size.error().code == ErrorCode::kNotFound)
    GTEST_SKIP() << "Dummy driver not loadable under the emulator";
  EXPECT_EQ(size.error().code, ErrorCode::kUnsupported) << size.error().message;
  EXPECT_NE(size.error().message.find("320x240"), std::string::npos) << size.error().message;
}

TEST(CameraLost, OnlyForLiveSources) {
  SourceInfo live;
  live.live = true;
  SourceInfo replay;
  EXPECT_TRUE(is_camera_lost(live, error(ErrorCode::kNotFound, "openni2:: camera lost: x")));
  EXPECT_FALSE(is_camera_lost(live, error(ErrorCode::kCorruptData, "bad frame")));
  EXPECT_FALSE(is_camera_lost(replay, error(ErrorCode::kNotFound, "rgb/1.png: not found")));
}

}  // namespace
}  // namespace ef

namespace ef {
namespace {

TEST(OpenNi2, FirstDeviceWhenThereIsNone) {
  if (!openni2_built()) GTEST_SKIP() << "built without libopenni2-dev";
  // Software devices (the Dummy) are not enumerated until opened by URI: "openni2:" wants hardware.
  auto src = open_source("openni2:?timeout_ms=3000");
  if (src.ok())
    GTEST_SKIP() << "'openni2:' opened a device: a camera is plugged in, or a Dummy device opened earlier in "
                    "this process stays listed by OpenNI2";
  EXPECT_EQ(src.error().code, ErrorCode::kNotFound) << src.error().message;
  EXPECT_NE(src.error().message.find("no OpenNI2 device found"), std::string::npos) << src.error().message;
}

}  // namespace
}  // namespace ef
