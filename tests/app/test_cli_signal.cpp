// SIGTERM (and SIGINT) in the middle of `edgefusion run`: the run stops after the frame in hand,
// exits 0, and its outputs are complete and agree with each other. And --realtime pacing.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <string>
#include <thread>

#include "app/cli_test_util.h"
#include "firmware_app/stop_signal.h"
#include "io/ply_writer.h"
#include "io/image_codec.h"
#include "io/trajectory_io.h"
#include "test_support.h"

namespace ef::app {
namespace {

void check_stops_cleanly(int sig, const char* name) {
  const auto dir = test::scratch_dir(std::string("cli-signal-") + name);
  // 1000 frames take many seconds. The handlers are installed before trajectory.txt is created, so
  // the signal is sent once that file exists (plus a second, for some frames to be mapped).
  const auto traj_path = dir / "trajectory.txt";
  std::thread killer([sig, traj_path] {
    for (int i = 0; i < 6000 && !std::filesystem::exists(traj_path); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(1000));
    std::raise(sig);
  });
  const auto r = cli({"run", "--source", "synthetic:?frames=1000&size=160x120", "--resolution", "160x120",
                      "--no-labels", "--out", dir.string(), "--quiet"});
  killer.join();
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find(std::string(name) + " received"), std::string::npos) << r.err;

  auto traj = read_tum_trajectory((dir / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  const std::size_t n = traj->poses.size();
  EXPECT_LT(n, 1000u);
  const std::string stats = read_file(dir / "stats.json");
  EXPECT_NE(stats.find("\"frames\":" + std::to_string(n) + ","), std::string::npos) << stats;
  EXPECT_NE(stats.find("\"stopped_by_signal\":1"), std::string::npos) << stats;
  EXPECT_EQ(stats.rfind("{\"state\":\"stopped\",", 0), 0u) << stats;
  auto map = read_surfel_ply((dir / "map.ply").string());
  ASSERT_TRUE(map.ok()) << to_string(map.error());
  if (n > 0) {
    EXPECT_GT(map->size(), 100u);
  }
}

// Each SIGINT / SIGTERM is counted, so that a pass after the run's own stop (the final labels) can
// stop at the next one; the previous handlers come back with the scope's end.
TEST(CliSignal, StopSignalsAreCountedInTheirScope) {
  {
    StopSignalScope scope;
    EXPECT_FALSE(scope.stop_requested());
    EXPECT_EQ(scope.signals(), 0);
    std::raise(SIGTERM);
    EXPECT_TRUE(scope.stop_requested());
    EXPECT_EQ(scope.signal_number(), SIGTERM);
    std::raise(SIGINT);
    EXPECT_EQ(scope.signals(), 2);
    EXPECT_EQ(scope.signal_number(), SIGINT);
  }
  StopSignalScope again;  // a new scope starts from none
  EXPECT_EQ(again.signals(), 0);
  EXPECT_FALSE(again.stop_requested());
}

TEST(CliSignal, SigtermMidRunWritesCompleteOutputs) { check_stops_cleanly(SIGTERM, "SIGTERM"); }
TEST(CliSignal, SigintMidRunWritesCompleteOutputs) { check_stops_cleanly(SIGINT, "SIGINT"); }

// --realtime paces a replay by its timestamps: 10 frames of a 30 Hz recording span 9/30 s.
TEST(CliRealtime, ReplayAtRecordedSpeedTakesTheRecordedTime) {
  const auto dir = test::scratch_dir("cli-realtime");
  const auto start = std::chrono::steady_clock::now();
  const auto r = cli({"run", "--source", "synthetic:?frames=10&size=160x120", "--resolution", "160x120",
                      "--no-labels", "--realtime", "--out", dir.string(), "--quiet"});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GE(seconds, 9.0 / 30.0 - 0.005);
  EXPECT_NE(read_file(dir / "stats.json").find("\"frames\":10,"), std::string::npos);
}

// `segment` on SIGTERM (issue 33, rough edge 10): it finishes the frame in hand, prints its summary
// saying it was stopped, and exits 0 with whole images.
TEST(CliSignal, SegmentStopsOnSigtermWithItsSummary) {
  const auto dir = test::scratch_dir("cli-signal-segment");
  const auto labels = dir / "labels";
  std::thread killer([labels] {
    for (int i = 0; i < 6000; ++i) {
      std::error_code ec;
      if (std::filesystem::exists(labels, ec) && !std::filesystem::is_empty(labels, ec)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    std::raise(SIGTERM);
  });
  const auto r = cli({"segment", "--source", "synthetic:?frames=1000&size=160x120", "--out", dir.string(), "--quiet"});
  killer.join();
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("SIGTERM received after"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("; stopped by a signal"), std::string::npos) << r.out;
  int images = 0;
  for (const auto& e : std::filesystem::directory_iterator(labels)) {
    Image<uint8_t> ids;
    EXPECT_TRUE(read_png_u8(e.path().string(), ids).ok()) << e.path();
    ++images;
  }
  EXPECT_GT(images, 0);
  EXPECT_LT(images, 1000);
  EXPECT_NE(r.out.find("segmented " + std::to_string(images) + " of "), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ef::app
