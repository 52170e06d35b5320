// The V4L2 camera source: errors without a device, and streaming where a /dev/video* exists.
#include <gtest/gtest.h>

#include <filesystem>

#include "platform/devices/cameras.h"
#include "sources/open_source.h"

namespace ef {
namespace {

TEST(V4l2, MissingDeviceNamesThePath) {
  auto r = open_source("v4l2:/dev/video-edgefusion-missing");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/dev/video-edgefusion-missing"), std::string::npos) << r.error().message;
  if (v4l2_built()) {
    EXPECT_EQ(r.error().code, ErrorCode::kNotFound) << r.error().message;
  } else {
    EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(r.error().message.find("not built: missing package libv4l-dev"), std::string::npos);
  }
}

TEST(V4l2, BadArguments) {
  if (!v4l2_built()) GTEST_SKIP() << "built without libv4l-dev";
  auto none = open_source("v4l2:");
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::kInvalidArgument);
  auto format = open_source("v4l2:/dev/video0?format=mjpeg");
  ASSERT_FALSE(format.ok());
  EXPECT_NE(format.error().message.find("format=mjpeg"), std::string::npos) << format.error().message;
  auto not_device = open_source("v4l2:/etc/hostname");
  ASSERT_FALSE(not_device.ok());
  EXPECT_EQ(not_device.error().code, ErrorCode::kInvalidArgument) << not_device.error().message;
  EXPECT_NE(not_device.error().message.find("/etc/hostname"), std::string::npos);
}

TEST(V4l2, StreamsARealDevice) {
  if (!v4l2_built()) GTEST_SKIP() << "built without libv4l-dev";
  std::string device;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/dev", ec))
    if (e.path().filename().string().rfind("video", 0) == 0) {
      device = e.path().string();
      break;
    }
  if (device.empty()) GTEST_SKIP() << "no /dev/video* on this machine: streaming needs a V4L2 camera (or vivid)";
  auto src = open_source("v4l2:" + device + "?size=320x240");
  if (!src.ok() && (src.error().code == ErrorCode::kUnsupported || src.error().code == ErrorCode::kIoError))
    GTEST_SKIP() << device << " is not a usable capture device here: " << src.error().message;
  ASSERT_TRUE(src.ok()) << src.error().message;
  const SourceInfo& info = (*src)->info();
  EXPECT_TRUE(info.live);
  EXPECT_TRUE(info.has_color);
  Frame frame;
  double last_t = -1;
  for (int i = 0; i < 5; ++i) {
    auto r = (*src)->next(frame);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(frame.color.width(), info.intrinsics.width);
    EXPECT_EQ(frame.depth.width(), info.intrinsics.width);
    EXPECT_GT(frame.timestamp, last_t);
    last_t = frame.timestamp;
  }
}

}  // namespace
}  // namespace ef
