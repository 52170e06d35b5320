// A live camera through the whole of `edgefusion run`: OpenNI2's software Dummy device (Debian's
// libopenni2-0 ships it) streams into the mapper, which writes complete outputs. The Dummy shows a
// test pattern, so tracking may be lost; what is checked is the plumbing: one pose line per
// delivered frame, the statistics and the map. Also the front panel's configuration errors.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "app/cli_test_util.h"
#include "io/trajectory_io.h"
#include "devices/camera_test_util.h"
#include "test_support.h"

namespace ef::app {
namespace {

TEST(CliCamera, OpenNi2DummyStreamsThroughTheMapper) {
#ifndef EF_HAVE_OPENNI2
  GTEST_SKIP() << "built without OpenNI2 (libopenni2-dev missing)";
#else
  if (!test::openni2_dummy_driver_installed())
    GTEST_SKIP() << "OpenNI2's Dummy driver is not installed in " << test::openni2_driver_dir();
  const auto dir = test::scratch_dir("cli-camera");
  const auto r = cli({"run", "--source", "openni2:Dummy", "--frames", "6", "--no-labels", "--out", dir.string(),
                      "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto traj = read_tum_trajectory((dir / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  EXPECT_EQ(traj->poses.size(), 6u);
  for (std::size_t i = 1; i < traj->poses.size(); ++i)
    EXPECT_GT(traj->poses[i].timestamp, traj->poses[i - 1].timestamp) << i;  // the device's clock
  const std::string stats = read_file(dir / "stats.json");
  EXPECT_NE(stats.find("\"frames\":6,"), std::string::npos) << stats;
  EXPECT_NE(stats.find("\"camera_lost\":0"), std::string::npos) << stats;
  EXPECT_TRUE(std::filesystem::exists(dir / "map.ply"));
#endif
}

// The logging mode on a live camera: frames come through the capture ring; the log holds each one
// delivered, with the device's timestamps, and the dropped frames are counted.
TEST(CliCamera, OpenNi2DummyIsLoggedThroughTheCaptureRing) {
#ifndef EF_HAVE_OPENNI2
  GTEST_SKIP() << "built without OpenNI2 (libopenni2-dev missing)";
#else
  if (!test::openni2_dummy_driver_installed())
    GTEST_SKIP() << "OpenNI2's Dummy driver is not installed in " << test::openni2_driver_dir();
  const auto dir = test::scratch_dir("cli-camera-log");
  const std::string log = (dir / "field.mcap").string();
  const auto r = cli({"log", "--source", "openni2:Dummy", "--frames", "8", "--out", log, "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("logged 8 frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("camera frames dropped: "), std::string::npos) << r.out;
  const auto m = cli({"run", "--source", "mcap:" + log, "--no-labels", "--out", (dir / "mapped").string(), "--quiet"});
  ASSERT_EQ(m.code, 0) << m.err;
  auto traj = read_tum_trajectory((dir / "mapped" / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  EXPECT_EQ(traj->poses.size(), 8u);
  for (std::size_t i = 1; i < traj->poses.size(); ++i)
    EXPECT_GT(traj->poses[i].timestamp, traj->poses[i - 1].timestamp) << i;  // the device's clock, kept
#endif
}

// The front panel: a configured chip that does not exist stops the run before it starts, naming
// the chip; marked optional, it is a warning and the run goes on without the LED.
TEST(CliCamera, MissingGpioChipIsAnErrorOrAWarning) {
  const auto dir = test::scratch_dir("cli-gpio");
  const auto cfg = dir / "run.yaml";
  std::ofstream(cfg) << "source: synthetic:?frames=2&size=160x120\nresolution: 160x120\nlabels: false\n"
                        "gpio:\n  led_chip: gpiochip-absent-7\n  led_line: 3\n";
  auto r = cli({"run", "--config", cfg.string(), "--out", (dir / "a").string(), "--quiet"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("gpiochip-absent-7"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "a" / "trajectory.txt"));

  std::ofstream(cfg, std::ios::app) << "  optional: true\n";
  r = cli({"run", "--config", cfg.string(), "--out", (dir / "b").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("edgefusion run: warning: GPIO status LED disabled: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("gpiochip-absent-7"), std::string::npos) << r.err;
  // Issue 33, rough edge 9: one prefix, no blank line after it.
  EXPECT_EQ(r.err.find("warning: warning:"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("\n\n"), std::string::npos) << r.err;
  EXPECT_NE(read_file(dir / "b" / "stats.json").find("\"frames\":2,"), std::string::npos);
}

}  // namespace
}  // namespace ef::app
