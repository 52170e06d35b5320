// `edgefusion run` as the shipped systemd service runs it (issue 32): it tells systemd when it is
// ready, proves it is alive at each frame and says when it stops (sd_notify through libsystemd, read
// here from a real notification socket); after a power cut it continues the interrupted run instead
// of starting over; a camera that is not there is exit status 3, which the unit restarts on; and an
// installed program finds its models beside it.
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "app/cli_test_util.h"
#include "firmware_app/commands.h"
#include "io/trajectory_io.h"
#include "pipeline/model_paths.h"
#include "pipeline/run_folder.h"
#include "platform/devices/cameras.h"
#include "platform/devices/service_notify.h"
#include "test_support.h"

namespace ef::app {
namespace {

namespace fs = std::filesystem;

// A datagram socket standing in for systemd's notification socket, and the environment a
// Type=notify service with WatchdogSec= gets, for the scope.
class NotifySocket {
 public:
  NotifySocket(const fs::path& path, int64_t watchdog_us) : path_(path) {
    fs::remove(path_);
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path_.c_str());
    ok_ = fd_ >= 0 && path_.string().size() < sizeof addr.sun_path &&
          bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
    setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    setenv("WATCHDOG_USEC", std::to_string(watchdog_us).c_str(), 1);
    setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  }
  ~NotifySocket() {
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
    unsetenv("WATCHDOG_PID");
    if (fd_ >= 0) close(fd_);
    fs::remove(path_);
  }
  bool ok() const { return ok_; }
  // Reads the socket on a thread of its own while the run goes on, as systemd does (a datagram
  // socket holds only a few unread messages before sd_notify blocks).
  void start_reading() {
    reader_ = std::thread([this] {
      char buf[4096];
      while (!stop_.load()) {
        const ssize_t n = recv(fd_, buf, sizeof buf, 0);
        if (n >= 0) messages_.emplace_back(buf, static_cast<size_t>(n));
        else std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    });
  }
  // Every datagram received, in order, once the reader is stopped.
  std::vector<std::string> messages() {
    stop_ = true;
    if (reader_.joinable()) reader_.join();
    char buf[4096];
    for (ssize_t n; (n = recv(fd_, buf, sizeof buf, 0)) >= 0;) messages_.emplace_back(buf, static_cast<size_t>(n));
    return messages_;
  }

 private:
  fs::path path_;
  int fd_ = -1;
  bool ok_ = false;
  std::thread reader_;
  std::atomic<bool> stop_{false};
  std::vector<std::string> messages_;
};

TEST(CliService, NotifiesReadyAliveAndStopping) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  if (!ServiceNotifier::built_with_systemd()) GTEST_SKIP() << "built without libsystemd (libsystemd-dev)";
  const auto dir = test::scratch_dir("cli-service-notify");
  // A watchdog of 40 ms: a ping is due every 10 ms of mapping, so a run of 60 frames sends several.
  NotifySocket sock(dir / "notify.sock", 40'000);
  ASSERT_TRUE(sock.ok()) << "cannot bind " << (dir / "notify.sock");
  sock.start_reading();
  const auto r = cli({"run", "--source", "synthetic:?frames=60&size=160x120", "--resolution", "160x120",
                      "--no-labels", "--out", (dir / "run").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::vector<std::string> m = sock.messages();
  ASSERT_FALSE(m.empty()) << "no notification reached the socket";
  // READY first (with the source in its status), WATCHDOG pings while mapping, STOPPING last.
  EXPECT_EQ(m.front().rfind("READY=1\nSTATUS=mapping synthetic:", 0), 0u) << m.front();
  EXPECT_EQ(m.back().rfind("STOPPING=1\nSTATUS=writing the outputs of 60 frames", 0), 0u) << m.back();
  int pings = 0;
  for (std::size_t i = 1; i + 1 < m.size(); ++i) {
    // Each ping carries the progress line for `systemctl status`.
    EXPECT_EQ(m[i].rfind("WATCHDOG=1\nSTATUS=tracking, ", 0), 0u) << m[i];
    ++pings;
  }
  EXPECT_GE(pings, 2) << "pings while mapping 60 frames with a 40 ms watchdog";
}

TEST(CliService, WithoutNotifySocketNothingIsSent) {
  unsetenv("NOTIFY_SOCKET");
  ServiceNotifier n;
  EXPECT_FALSE(n.enabled());
  EXPECT_FALSE(n.alive(1'000'000));
  n.ready("x");
  EXPECT_EQ(n.sent(), 0);
}

// The service after a power cut: `out` has {time} and output.resume_interrupted; the newest run
// never wrote its end (its stats.json still says "running", as a killed run's does: the kill tests
// of issue 29 show that), so the next start continues it in its folder. A run that ended is not
// continued: the next start makes a new folder.
TEST(CliService, ContinuesTheInterruptedRunAfterAPowerCut) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-service-resume");
  const std::string out = (dir / "runs" / "{time}").string();
  const std::vector<std::string> base = {"run", "--source", "synthetic:?frames=40&size=160x120", "--resolution",
                                         "160x120", "--no-labels", "--out", out, "--resume-interrupted", "--quiet"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = base;
    a.insert(a.end(), extra.begin(), extra.end());
    return cli(a);
  };
  // The first start: no earlier run.
  auto r = with({"--frames", "20"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("starting a new run: no earlier run"), std::string::npos) << r.err;
  const fs::path first = fs::canonical(dir / "runs" / "latest");
  ASSERT_EQ(pipeline::run_state(first.string()), "finished");
  // Power cut: the run's end was never written.
  {
    std::string stats = read_file(first / "stats.json");
    const std::string done = "{\"state\":\"finished\"";
    ASSERT_EQ(stats.rfind(done, 0), 0u) << stats;
    stats.replace(0, done.size(), "{\"state\":\"running\"");
    std::ofstream(first / "stats.json", std::ios::trunc) << stats;
  }
  pipeline::RunOptions options;
  options.out = out;
  const pipeline::InterruptedRun found = pipeline::find_interrupted_run(options);
  EXPECT_EQ(found.folder, first.string()) << found.why;
  EXPECT_EQ(found.frames, 20);

  // The restart continues it: same folder, 40 poses in all, and it ends "finished".
  r = with({"--frames", "40"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("continuing the interrupted run " + first.string()), std::string::npos) << r.err;
  EXPECT_EQ(fs::canonical(dir / "runs" / "latest"), first);
  auto traj = read_tum_trajectory((first / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  EXPECT_EQ(traj->poses.size(), 40u);
  EXPECT_EQ(pipeline::run_state(first.string()), "finished");

  // A run that ended is not continued: a new folder.
  r = with({"--frames", "10"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("starting a new run: the newest run " + first.string() + " ended (finished)"),
            std::string::npos)
      << r.err;
  EXPECT_NE(fs::canonical(dir / "runs" / "latest"), first);
  int folders = 0;
  for (const auto& e : fs::directory_iterator(dir / "runs")) folders += e.is_directory() && !e.is_symlink();
  EXPECT_EQ(folders, 2);
}

TEST(CliService, RunStateReadsTheFirstKeyOfStatsJson) {
  const auto dir = test::scratch_dir("cli-service-state");
  EXPECT_EQ(pipeline::run_state(dir.string()), "") << "no stats.json";
  std::ofstream(dir / "stats.json") << "{\"state\":\"failed: a \\\"quoted\\\" reason\",\"frames\":3}";
  EXPECT_EQ(pipeline::run_state(dir.string()), "failed: a \"quoted\" reason");
  std::ofstream(dir / "stats.json", std::ios::trunc) << "{\"state\":\"runn";
  EXPECT_EQ(pipeline::run_state(dir.string()), "") << "cut off";
  std::ofstream(dir / "stats.json", std::ios::trunc) << "{\"frames\":3,\"state\":\"running\"}";
  EXPECT_EQ(pipeline::run_state(dir.string()), "") << "not the first key";
}

// A camera that is not there at the start: exit status 3 (the unit's Restart=on-failure retries
// it), not 2 (a configuration error, never restarted). Through OpenNI2's real driver stack.
TEST(CliService, AbsentCameraIsExitStatusThree) {
  if (!openni2_built()) GTEST_SKIP() << "built without OpenNI2 (libopenni2-dev)";
  const auto dir = test::scratch_dir("cli-service-camera");
  const auto r = cli({"run", "--source", "openni2:no-such-camera-serial-0000", "--no-labels", "--out",
                      (dir / "run").string(), "--quiet"});
  EXPECT_EQ(r.code, kExitCameraLost) << r.err;
  EXPECT_NE(r.err.find("no-such-camera-serial-0000"), std::string::npos) << r.err;
}

// An installed program (any prefix: /usr, /usr/local, a package unpacked into a folder) finds the
// models in <prefix>/share/edgefusion/models from its own location.
TEST(CliService, InstalledProgramFindsItsModelsBesideIt) {
  const auto dir = test::scratch_dir("cli-service-prefix");
  const fs::path prefix = dir / "prefix";
  fs::create_directories(prefix / "bin");
  const std::string exe = (prefix / "bin" / "edgefusion").string();
  EXPECT_EQ(pipeline::installed_models_dir(exe), "") << "no share/edgefusion/models yet";
  fs::create_directories(prefix / "share" / "edgefusion" / "models");
  EXPECT_EQ(pipeline::installed_models_dir(exe), (prefix / "share" / "edgefusion" / "models").string());
  EXPECT_EQ(pipeline::installed_models_dir(""), "");
  // This test program lives in the build tree: no share/ beside it, so the source tree's models.
  EXPECT_FALSE(pipeline::this_program_path().empty());
  EXPECT_TRUE(fs::exists(fs::path(pipeline::models_dir()) / pipeline::kRealModelFile)) << pipeline::models_dir();
}

}  // namespace
}  // namespace ef::app
