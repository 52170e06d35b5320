// Never lose a run (issue 29): `edgefusion run` killed with SIGKILL, on a full disk, and into a
// folder that holds an earlier run. What the robot accepted before the kill is on disk, readable.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include "app/cli_test_util.h"
#include "core/frame.h"
#include "io/image_codec.h"
#include "io/mcap_reader.h"
#include "io/ply_writer.h"
#include "io/trajectory_io.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef::app {
namespace {

namespace fs = std::filesystem;

// The number after "key": in a stats.json text (-1 when absent).
double json_number(const std::string& text, const std::string& key) {
  const auto at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return -1;
  return std::stod(text.substr(at + key.size() + 3));
}

// The "state" of a stats.json text ("" when absent).
std::string json_state(const std::string& text) {
  const std::string key = "{\"state\":\"";
  if (text.rfind(key, 0) != 0) return "";
  const auto end = text.find('"', key.size());
  return end == std::string::npos ? "" : text.substr(key.size(), end - key.size());
}

// A stats.json whole: one object, ending with its newline.
void expect_whole_stats(const std::string& text) {
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.front(), '{');
  EXPECT_EQ(text.substr(text.size() - 2), "}\n") << text;
}

// Runs `args` through the command line in a child process of its own (its output discarded), waits
// until `ready()` (polled every 2 ms, at most `limit_ms`), then `after_ms` more, and kills it with
// SIGKILL. Returns the child's wait status: WIFSIGNALED when the kill came before the run's end.
int run_and_kill(const std::vector<std::string>& args, const std::function<bool()>& ready, int after_ms,
                 int limit_ms = 60000) {
  const pid_t child = ::fork();
  if (child < 0) return 0;
  if (child == 0) {
    std::freopen("/dev/null", "w", stdout);
    std::freopen("/dev/null", "w", stderr);
    ::_exit(cli(args).code == 0 ? 100 : 101);  // reached only when the kill came too late
  }
  for (int waited = 0; waited < limit_ms && !ready(); waited += 2)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  std::this_thread::sleep_for(std::chrono::milliseconds(after_ms));
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  return status;
}

// The npm readers of our field logs (tests/npm: @mcap/core and Foxglove's ROS 2 decoders), run on
// `file`: their JSON line, or "" with the reason in `why` when node or the readers are missing (the
// README's test command installs them) or the tests run under an emulator.
std::string npm_mcap_summary(const std::string& file, std::string& why) {
  const fs::path npm = fs::path(EF_SOURCE_DIR) / "tests" / "npm";
  if (test::kUnderEmulator) {
    why = "under qemu-user: node is a host program";
    return "";
  }
  if (std::system("command -v node >/dev/null 2>&1") != 0) {
    why = "node is not installed (scripts/install-deps.sh test installs it)";
    return "";
  }
  if (!fs::exists(npm / "node_modules" / "@mcap" / "core")) {
    why = "tests/npm/node_modules is missing (scripts/install-deps.sh test runs npm ci there)";
    return "";
  }
  const std::string cmd = "node '" + (npm / "mcap_summary.mjs").string() + "' '" + file + "' 2>&1";
  std::FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) {
    why = "popen failed";
    return "";
  }
  std::string out;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = ::pclose(p);
  EXPECT_EQ(status, 0) << out;
  return out;
}

// The message count of `topic` in an npm summary's "counts" object (-1 when absent).
long npm_count(const std::string& summary, const std::string& topic) {
  const auto counts = summary.find("\"counts\":{");
  if (counts == std::string::npos) return -1;
  const auto end = summary.find('}', counts);
  const auto at = summary.find("\"" + topic + "\":", counts);
  if (at == std::string::npos || at > end) return -1;
  return std::stol(summary.substr(at + topic.size() + 3));
}

// Our reader's message count of `topic`.
long our_count(const McapReader& r, const std::string& topic) {
  const McapChannel* c = r.channel(topic);
  return c == nullptr ? -1 : static_cast<long>(c->messages);
}

TEST(CliOutputs, ARunNeverOverwritesAnEarlierRun) {
  const auto dir = test::scratch_dir("cli-outputs-refuse");
  const std::string out = (dir / "run").string();
  const std::vector<std::string> run = {"run", "--source", "synthetic:?frames=4&size=160x120", "--resolution",
                                        "160x120", "--no-labels", "--quiet", "--out", out};
  auto r = cli(run);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string map_a = read_file(fs::path(out) / "map.ply");

  // The second run into the same folder is refused before anything is touched, and so is its plan.
  r = cli(run);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("holds an earlier run (trajectory.txt, map.ply, stats.json, checkpoint.efs, config.yaml, preview.png, report.html)"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  EXPECT_EQ(read_file(fs::path(out) / "map.ply"), map_a);
  r = cli({"plan", "--source", "synthetic:?frames=4&size=160x120", "--out", out});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("holds an earlier run"), std::string::npos) << r.err;

  // --overwrite replaces the run whole: the earlier outputs and a killed run's leftovers go first.
  std::FILE* leftover = std::fopen((fs::path(out) / "map.ply.partial").c_str(), "w");
  ASSERT_NE(leftover, nullptr);
  std::fclose(leftover);
  auto overwrite = run;
  overwrite[2] = "synthetic:?frames=2&size=160x120";
  overwrite.push_back("--overwrite");
  r = cli(overwrite);
  ASSERT_EQ(r.code, 0) << r.err;
  auto traj = read_tum_trajectory((fs::path(out) / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok());
  EXPECT_EQ(traj->poses.size(), 2u);
  EXPECT_EQ(json_number(read_file(fs::path(out) / "stats.json"), "frames"), 2);
  EXPECT_FALSE(fs::exists(fs::path(out) / "map.ply.partial"));
  EXPECT_FALSE(fs::exists(fs::path(out) / ".stats.json.next"));  // the reserve goes with the run
}

TEST(CliOutputs, TimeInTheFolderGivesEachRunItsOwnAndALatestLink) {
  const auto dir = test::scratch_dir("cli-outputs-time");
  const std::vector<std::string> run = {"run", "--source", "synthetic:?frames=2&size=160x120", "--resolution",
                                        "160x120", "--no-labels", "--quiet", "--out", (dir / "runs/{time}").string()};
  for (int i = 0; i < 2; ++i) {
    auto r = cli(run);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("run folder " + (dir / "runs").string() + "/"), std::string::npos) << r.err;
  }
  std::vector<std::string> folders;
  for (const auto& e : fs::directory_iterator(dir / "runs"))
    if (!e.is_symlink()) folders.push_back(e.path().filename().string());
  std::sort(folders.begin(), folders.end());
  ASSERT_EQ(folders.size(), 2u);
  EXPECT_EQ(folders[0].size(), 15u) << folders[0];  // YYYYmmdd-HHMMSS
  EXPECT_TRUE(fs::is_symlink(dir / "runs" / "latest"));
  EXPECT_EQ(fs::read_symlink(dir / "runs" / "latest").string(), folders[1]);  // the newest
  for (const auto& f : folders) {
    EXPECT_EQ(json_state(read_file(dir / "runs" / f / "stats.json")), "finished");
    EXPECT_TRUE(fs::exists(dir / "runs" / f / "map.ply"));
  }
}

// SIGKILL at a moment of the run: the trajectory has a whole line per mapped frame up to the kill,
// stats.json parses and says "running", and no output is half written.
TEST(CliOutputs, SigkillLeavesAReadableTrajectoryAndRunningStats) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-kill");
  const fs::path out = dir / "run";
  // Killed once stats.json has been rewritten during the run with some frames mapped.
  double frames_in_stats = 0;
  const int status = run_and_kill(
      {"run", "--source", "synthetic:?frames=100000&size=160x120", "--resolution", "160x120", "--no-labels",
       "--quiet", "--stats-seconds", "0.2", "--sync-seconds", "0.5", "--out", out.string()},
      [&] {
        const std::string text = read_file(out / "stats.json");
        if (!text.empty()) frames_in_stats = json_number(text, "frames");
        return frames_in_stats >= 20;
      },
      150);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before the kill (status " << status << ")";
  ASSERT_GE(frames_in_stats, 20) << "stats.json was not rewritten during the run";

  const std::string stats = read_file(out / "stats.json");
  expect_whole_stats(stats);
  EXPECT_EQ(json_state(stats), "running");
  const double frames = json_number(stats, "frames");
  auto traj = read_tum_trajectory((out / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  EXPECT_EQ(traj->cut_line, 0);
  // Every frame mapped before the last stats.json has its line (and later ones may too).
  EXPECT_GE(static_cast<double>(traj->poses.size()), frames);
  EXPECT_FALSE(fs::exists(out / "map.ply"));  // written at the end only: absent, never half
  EXPECT_FALSE(fs::exists(out / "map.ply.partial"));
}

// preview.png is drawn again with each checkpoint (issue 33): a run killed after its first
// checkpoint leaves the picture of that map, whole, beside the checkpoint.
TEST(CliOutputs, SigkillLeavesThePreviewOfTheLastCheckpoint) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-kill-preview");
  const fs::path out = dir / "run";
  const int status = run_and_kill({"run", "--source", "synthetic:?frames=100000&size=160x120", "--resolution",
                                   "160x120", "--no-labels", "--quiet", "--checkpoint-seconds", "0.3", "--out",
                                   out.string()},
                                  [&] { return fs::exists(out / "preview.png"); }, 0, 120000);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before the kill (status " << status << ")";
  ASSERT_TRUE(fs::exists(out / "checkpoint.efs"));
  Image<Rgb8> png;
  const Status read = read_color_image((out / "preview.png").string(), png);
  ASSERT_TRUE(read.ok()) << to_string(read.error());
  EXPECT_EQ(png.width(), 2 * 640);
  EXPECT_GT(png.height(), 480);
  // The map is drawn: a good part of the colour panel is not the background.
  int drawn = 0;
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x) drawn += !(png.view()(x, y) == Rgb8{246, 246, 246});
  EXPECT_GT(drawn, 640 * 480 / 20) << "the checkpoint's preview shows no map";
  EXPECT_FALSE(fs::exists(out / "map.ply"));
}

// A full disk: the run ends with an error naming the file and the reason, stats.json says
// "failed: ..." (written into its reserved blocks), and nothing is half written.
TEST(CliOutputs, AFullDiskEndsTheRunWithFailedStatsAndWholeFiles) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  test::SmallDisk disk("cli-outputs-full", 512 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  // The final checkpoint and the map (60 and 40 bytes a surfel, some 20,000 surfels at 320x240) do
  // not fit; the trajectory does.
  const fs::path out = disk.dir() / "run";
  auto r = cli({"run", "--source", "synthetic:?frames=12&size=320x240", "--resolution", "320x240", "--no-labels",
                "--quiet", "--out", out.string()});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("checkpoint.efs: write failed"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("map.ply: write failed"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  const std::string stats = read_file(out / "stats.json");
  expect_whole_stats(stats);
  // The state names the first output that failed.
  EXPECT_EQ(json_state(stats).rfind("failed: ", 0), 0u) << stats;
  EXPECT_NE(json_state(stats).find("checkpoint.efs: write failed"), std::string::npos) << stats;
  EXPECT_FALSE(fs::exists(out / "checkpoint.efs"));
  EXPECT_FALSE(fs::exists(out / "checkpoint.efs.partial"));
  EXPECT_FALSE(fs::exists(out / "map.ply"));
  EXPECT_FALSE(fs::exists(out / "map.ply.partial"));
  auto traj = read_tum_trajectory((out / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  EXPECT_EQ(traj->poses.size(), 12u);
}

// The disk fills while the trajectory is written: the run stops at that frame with the error,
// every line in the file is whole, and stats.json still says why.
TEST(CliOutputs, ATrajectoryThatFillsTheDiskStopsTheRunWithWholeLines) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  test::SmallDisk disk("cli-outputs-full-traj", 1024 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  // Leave about 100 kB: stats.json and its 64 kB reserve, the configuration (about 12 kB, 16 kB of
  // tmpfs pages), and some hundred trajectory lines. With less, the reserve cannot be made at the
  // start (not an error, durable_file.h) and the final stats.json finds no room.
  {
    std::FILE* f = std::fopen((disk.dir() / "filler").c_str(), "wb");
    ASSERT_NE(f, nullptr);
    const std::string block(4096, 'x');
    const auto free_bytes = [&] { return fs::space(disk.dir()).available; };
    while (free_bytes() > 100 * 1024 && std::fwrite(block.data(), 1, block.size(), f) == block.size()) std::fflush(f);
    std::fclose(f);
  }
  const fs::path out = disk.dir() / "run";
  // No periodic checkpoint: under qemu the run is slow enough for the 30 s one to fill the disk first.
  auto r = cli({"run", "--source", "synthetic:?frames=3000&size=160x120", "--resolution", "160x120", "--no-labels",
                "--checkpoint-seconds", "0", "--quiet", "--out", out.string()});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("trajectory.txt: write failed after"), std::string::npos) << r.err;
  const std::string stats = read_file(out / "stats.json");
  expect_whole_stats(stats);
  EXPECT_NE(json_state(stats).find("trajectory.txt: write failed"), std::string::npos) << r.err << stats;
  auto traj = read_tum_trajectory((out / "trajectory.txt").string());
  ASSERT_TRUE(traj.ok()) << to_string(traj.error());
  EXPECT_EQ(traj->cut_line, 0);
  EXPECT_GT(traj->poses.size(), 20u);
  EXPECT_LT(traj->poses.size(), 3000u);
  EXPECT_FALSE(fs::exists(out / "map.ply.partial"));
}

// `convert` stops on SIGTERM like `run`: the frames so far are a whole recording, exit 0.
TEST(CliOutputs, ConvertStopsOnSigtermWithAWholeRecording) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-convert-term");
  const fs::path klg = dir / "cut.klg";
  std::thread killer([klg] {
    for (int i = 0; i < 6000 && !fs::exists(klg); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    std::raise(SIGTERM);
  });
  const auto r = cli({"convert", "--source", "synthetic:?frames=100000&size=160x120", "--to", "klg:" + klg.string(),
                      "--quiet"});
  killer.join();
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("SIGTERM received after"), std::string::npos) << r.err;
  auto src = open_source("klg:" + klg.string() + "?size=160x120");
  ASSERT_TRUE(src.ok()) << to_string(src.error());
  EXPECT_EQ((*src)->info().warning, "");  // whole: its count is right
  EXPECT_GT((*src)->info().frame_count, 0);
  EXPECT_LT((*src)->info().frame_count, 100000);
  EXPECT_NE(r.out.find("converted " + std::to_string((*src)->info().frame_count) + " frames"), std::string::npos)
      << r.out;
}

// SIGKILL in the middle of `convert`: the .klg and the TUM folder read back, every frame whole.
TEST(CliOutputs, ConvertKilledLeavesReadableRecordings) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-convert-kill");
  for (const std::string& to : {"klg:" + (dir / "cut.klg").string(), "tum:" + (dir / "tum").string()}) {
    const fs::path list = to[0] == 'k' ? dir / "cut.klg" : dir / "tum" / "depth.txt";
    // Killed once some frames are written (the file or list has grown past its header).
    const int status = run_and_kill(
        {"convert", "--source", "synthetic:?frames=100000&size=160x120", "--to", to, "--quiet"},
        [&] {
          std::error_code ec;
          return fs::exists(list, ec) && fs::file_size(list, ec) > (to[0] == 'k' ? 200'000u : 500u);
        },
        37);
    ASSERT_TRUE(WIFSIGNALED(status)) << to << ": ended before the kill (status " << status << ")";
    auto src = open_source(to[0] == 'k' ? to + "?size=160x120" : to);
    ASSERT_TRUE(src.ok()) << to << ": " << to_string(src.error());
    const int64_t n = (*src)->info().frame_count;
    EXPECT_GT(n, 2) << to;
    Frame f;
    int64_t read = 0;
    while (true) {
      auto got = (*src)->next(f);
      ASSERT_TRUE(got.ok()) << to << ", frame " << read << ": " << to_string(got.error());
      if (!*got) break;
      ++read;
    }
    EXPECT_EQ(read, n) << to;
  }
}

// A run continued from its checkpoint is the run that was never interrupted: the same trajectory
// and map, byte for byte (labels included, in a deterministic run). A corrupt newest checkpoint is
// named and the one before it used.
TEST(CliOutputs, ResumeContinuesTheRunExactlyAndSurvivesACorruptCheckpoint) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-resume");
  const std::string source = "synthetic:bedroom?frames=90&size=160x120";
  const auto run = [&](const std::string& out, const std::vector<std::string>& more) {
    std::vector<std::string> a = {"run", "--source", source, "--resolution", "160x120", "--deterministic",
                                  "--label-every", "3", "--quiet", "--out", out};
    a.insert(a.end(), more.begin(), more.end());
    return cli(a);
  };
  const std::string whole = (dir / "whole").string(), parts = (dir / "parts").string();
  auto r = run(whole, {});
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(parts, {"--frames", "40"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(fs::path(parts) / "checkpoint.efs"));
  EXPECT_TRUE(fs::exists(fs::path(parts) / "config.yaml"));

  r = cli({"run", "--resume", parts, "--frames", "70", "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("resuming " + parts + " after frame 40"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(fs::path(parts) / "checkpoint.prev.efs"));  // frame 40's, kept
  // The newest checkpoint (frame 70) damaged: the run goes on from frame 40's, and says so.
  {
    std::FILE* f = std::fopen((fs::path(parts) / "checkpoint.efs").c_str(), "r+b");
    ASSERT_NE(f, nullptr);
    std::fseek(f, 5000, SEEK_SET);
    const int c = std::fgetc(f);
    std::fseek(f, 5000, SEEK_SET);
    std::fputc(c ^ 0x40, f);
    std::fclose(f);
  }
  r = cli({"run", "--resume", parts, "--frames", "90", "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: " + parts + "/checkpoint.efs at byte"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("CRC-32 mismatch"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("after frame 40"), std::string::npos) << r.err;

  EXPECT_EQ(read_file(fs::path(parts) / "trajectory.txt"), read_file(fs::path(whole) / "trajectory.txt"));
  EXPECT_TRUE(read_file(fs::path(parts) / "map.ply") == read_file(fs::path(whole) / "map.ply"))
      << "the resumed map differs from the uninterrupted one";
  const std::string stats = read_file(fs::path(parts) / "stats.json");
  EXPECT_EQ(json_number(stats, "frames"), 90);
  EXPECT_EQ(json_number(stats, "resumed_at_frame"), 40);
  EXPECT_EQ(json_number(stats, "cnn_frames"), json_number(read_file(fs::path(whole) / "stats.json"), "cnn_frames"));

  // export: the checkpoint's map is the run's map.ply.
  r = cli({"export", parts, "--out", (dir / "exported.ply").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  auto exported = read_surfel_ply((dir / "exported.ply").string());
  auto written = read_surfel_ply((fs::path(parts) / "map.ply").string());
  ASSERT_TRUE(exported.ok() && written.ok());
  ASSERT_EQ(exported->size(), written->size());
  EXPECT_EQ(exported->x, written->x);
  EXPECT_EQ(exported->class_id, written->class_id);
  EXPECT_EQ(exported->class_prob, written->class_prob);

  // What --resume refuses.
  r = cli({"run", "--resume", (dir / "nothing").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("not the folder of a run"), std::string::npos) << r.err;
  r = cli({"run", "--resume", parts, "--out", whole});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("takes no --config, --out or --overwrite"), std::string::npos) << r.err;
}

// SIGKILL after a checkpoint, then --resume: the finished trajectory is the uninterrupted run's.
TEST(CliOutputs, SigkillThenResumeGivesTheUninterruptedTrajectory) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-kill-resume");
  const std::string frames = std::to_string(test::frames_native_or_emulated(300, 60));
  const std::vector<std::string> run = {"run", "--source", "synthetic:?frames=100000&size=160x120", "--resolution",
                                        "160x120", "--no-labels", "--quiet", "--frames", frames,
                                        "--checkpoint-seconds", "0.3"};
  const fs::path killed = dir / "killed";
  // Killed as soon as the first checkpoint is in place (renamed there whole), some 0.3 s into a run
  // of about a second here: the frames after it are mapped again by the resumed run.
  auto a = run;
  a.insert(a.end(), {"--out", killed.string()});
  const int status = run_and_kill(a, [&] { return fs::exists(killed / "checkpoint.efs"); }, 0, 120000);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before the kill (status " << status << ")";

  auto r = cli({"run", "--resume", killed.string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  a = run;
  a.insert(a.end(), {"--out", (dir / "whole").string()});
  r = cli(a);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string resumed = read_file(killed / "trajectory.txt"), whole = read_file(dir / "whole" / "trajectory.txt");
  EXPECT_GT(whole.size(), 1000u);
  EXPECT_TRUE(resumed == whole) << "the resumed trajectory differs from the uninterrupted one";
  EXPECT_EQ(json_state(read_file(killed / "stats.json")), "finished");
}

// A full disk while a run logs: the log ends at its last whole chunk and says where it failed; the
// run reports it and stats.json says failed.
TEST(CliOutputs, AFullDiskCutsTheFieldLogAfterAWholeChunkAndTheRunSaysSo) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  test::SmallDisk disk("cli-outputs-log-full", 512 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  const fs::path out = disk.dir() / "run";
  auto r = cli({"run", "--source", "synthetic:?frames=60&size=160x120", "--resolution", "160x120", "--no-labels",
                "--quiet", "--checkpoint-seconds", "0", "--log", "log.mcap", "--log-chunk-seconds", "0.1",
                "--out", out.string()});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("log.mcap"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  const std::string stats = read_file(out / "stats.json");
  expect_whole_stats(stats);
  EXPECT_EQ(json_state(stats).rfind("failed: ", 0), 0u) << stats;
  McapReader log;
  ASSERT_TRUE(log.open((out / "log.mcap").string()).ok());
  EXPECT_FALSE(log.complete());
  EXPECT_GT(our_count(log, "/camera/depth"), 3);
  EXPECT_LT(our_count(log, "/camera/depth"), 60);
  std::string buf;
  for (const McapMessageRef& m : log.messages()) ASSERT_TRUE(log.read(m, buf).ok());
}

// A run's field log replays through `run --source mcap:` to the same trajectory: depth is lossless,
// and the colour logged as PNG is the recording's own (a .klg's decoded JPEG).
TEST(CliOutputs, ARunsFieldLogReplaysToTheSameTrajectory) {
  const auto dir = test::scratch_dir("cli-outputs-log-replay");
  const std::string klg = (dir / "rec.klg").string();
  auto r = cli({"convert", "--source", "synthetic:?frames=24&size=160x120", "--to", "klg:" + klg, "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  const fs::path a = dir / "a", b = dir / "b";
  r = cli({"run", "--source", "klg:" + klg + "?size=160x120", "--resolution", "160x120", "--no-labels", "--quiet",
           "--log", "log.mcap", "--log-color", "png", "--out", a.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("log: " + (a / "log.mcap").string() + " (24 frames)"), std::string::npos) << r.out;
  r = cli({"run", "--source", "mcap:" + (a / "log.mcap").string(), "--resolution", "160x120", "--no-labels",
           "--quiet", "--out", b.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string ta = read_file(a / "trajectory.txt"), tb = read_file(b / "trajectory.txt");
  EXPECT_GT(ta.size(), 500u);
  EXPECT_TRUE(ta == tb) << "the replayed trajectory differs from the original";

  McapReader log;
  ASSERT_TRUE(log.open((a / "log.mcap").string()).ok());
  EXPECT_TRUE(log.complete()) << log.warning();
  EXPECT_EQ(our_count(log, "/camera/depth"), 24);
  EXPECT_EQ(our_count(log, "/camera/color"), 24);
  EXPECT_EQ(our_count(log, "/edgefusion/pose"), 24);
  EXPECT_EQ(our_count(log, "/tf"), 24);
  EXPECT_EQ(our_count(log, "/camera/calibration"), 1);
  EXPECT_GE(our_count(log, "/log"), 2);  // started, finished
  EXPECT_EQ(our_count(log, "/edgefusion/map"), 1);  // at the final checkpoint

  // A log file that is there already is never overwritten.
  r = cli({"run", "--source", "klg:" + klg + "?size=160x120", "--resolution", "160x120", "--no-labels", "--quiet",
           "--log", (a / "log.mcap").string(), "--out", (dir / "c").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("a log is there already"), std::string::npos) << r.err;
  // A run that could not start left nothing behind: the same folder takes the next run, and a log
  // that cannot be created is an error naming it.
  EXPECT_FALSE(fs::exists(dir / "c" / "trajectory.txt"));
  r = cli({"run", "--source", "klg:" + klg + "?size=160x120", "--resolution", "160x120", "--no-labels", "--quiet",
           "--log", "/nonexistent-folder/field.mcap", "--out", (dir / "c").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("/nonexistent-folder/field.mcap"), std::string::npos) << r.err;
  r = cli({"run", "--source", "klg:" + klg + "?size=160x120", "--resolution", "160x120", "--no-labels", "--quiet",
           "--frames", "3", "--out", (dir / "c").string()});
  EXPECT_EQ(r.code, 0) << r.err;

  // With labels: each CNN result's class ids are in the log too.
  const fs::path c = dir / "labelled";
  r = cli({"run", "--source", "synthetic:?frames=21&size=160x120", "--resolution", "160x120", "--quiet", "--log",
           "log.mcap", "--out", c.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  McapReader labelled;
  ASSERT_TRUE(labelled.open((c / "log.mcap").string()).ok());
  const double cnn_frames = json_number(read_file(c / "stats.json"), "cnn_frames");
  EXPECT_GE(cnn_frames, 1);
  EXPECT_EQ(our_count(labelled, "/edgefusion/labels"), static_cast<long>(cnn_frames));

  std::string why;
  const std::string npm = npm_mcap_summary((a / "log.mcap").string(), why);
  if (npm.empty()) GTEST_SKIP() << "the @mcap/core check: " << why;
  EXPECT_NE(npm.find("\"indexed\":true"), std::string::npos) << npm;
  const std::string npm_labelled = npm_mcap_summary((c / "log.mcap").string(), why);
  EXPECT_EQ(npm_count(npm_labelled, "/edgefusion/labels"), static_cast<long>(cnn_frames)) << npm_labelled;
  EXPECT_NE(npm_labelled.find("\"point_stride\":17,"), std::string::npos) << npm_labelled;
  EXPECT_NE(npm_labelled.find("\"alpha\",\"class\"]"), std::string::npos) << npm_labelled;
  for (const char* topic :
       {"/camera/depth", "/camera/color", "/edgefusion/pose", "/tf", "/camera/calibration", "/log", "/edgefusion/map"})
    EXPECT_EQ(npm_count(npm, topic), our_count(log, topic)) << topic << ": " << npm;
  // The map, decoded by Foxglove's reader: a PointCloud with colour (and classes with labels).
  EXPECT_NE(npm.find("\"point_stride\":16,\"fields\":[\"x\",\"y\",\"z\",\"red\",\"green\",\"blue\",\"alpha\"]"),
            std::string::npos) << npm;
  EXPECT_NE(npm.find("\"/camera/depth\":\"foxglove_msgs/msg/CompressedImage\""), std::string::npos) << npm;
  EXPECT_NE(npm.find("\"/tf\":\"foxglove_msgs/msg/FrameTransform\""), std::string::npos) << npm;
}

// SIGKILL during a run with a field log: the log reads up to its last whole chunk, with our reader,
// the mcap: source and @mcap/core's streaming reader alike.
TEST(CliOutputs, SigkillLeavesAFieldLogReadableUpToItsLastChunk) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kProcessTestUnderEmulator;
  const auto dir = test::scratch_dir("cli-outputs-log-kill");
  const fs::path out = dir / "run";
  const fs::path log_path = out / "log.mcap";
  const int status = run_and_kill(
      {"run", "--source", "synthetic:?frames=100000&size=160x120", "--resolution", "160x120", "--no-labels",
       "--quiet", "--log", "log.mcap", "--log-chunk-seconds", "0.1", "--out", out.string()},
      [&] {
        std::error_code ec;
        return fs::file_size(log_path, ec) > 400000 && !ec;
      },
      50);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before the kill (status " << status << ")";
  McapReader log;
  ASSERT_TRUE(log.open(log_path.string()).ok());
  EXPECT_FALSE(log.complete());
  EXPECT_NE(log.warning().find("left out"), std::string::npos) << log.warning();
  const long depth = our_count(log, "/camera/depth");
  EXPECT_GT(depth, 3);
  auto src = open_source("mcap:" + log_path.string());
  ASSERT_TRUE(src.ok()) << to_string(src.error());
  EXPECT_EQ((*src)->info().frame_count, depth);
  EXPECT_FALSE((*src)->info().warning.empty());

  std::string why;
  const std::string npm = npm_mcap_summary(log_path.string(), why);
  if (npm.empty()) GTEST_SKIP() << "the @mcap/core check: " << why;
  EXPECT_NE(npm.find("\"indexed\":false"), std::string::npos) << npm;  // no summary: streamed
  for (const char* topic : {"/camera/depth", "/edgefusion/pose", "/camera/calibration"})
    EXPECT_EQ(npm_count(npm, topic), our_count(log, topic)) << topic << ": " << npm;
}

// `edgefusion log`: the low-power mode writes a log (and never over one), which replays and which
// @mcap/core reads.
TEST(CliOutputs, TheLoggingModeRecordsALogThatReplays) {
  const auto dir = test::scratch_dir("cli-outputs-log-mode");
  const std::string path = (dir / "field.mcap").string();
  const std::vector<std::string> log = {"log", "--source", "synthetic:?frames=12&size=160x120", "--out", path,
                                        "--quiet"};
  auto r = cli(log);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("logged 12 frames (160x120)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ms per frame"), std::string::npos) << r.out;
  r = cli(log);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("exists"), std::string::npos) << r.err;
  auto again = log;
  again.push_back("--overwrite");
  ASSERT_EQ(cli(again).code, 0);

  r = cli({"run", "--source", "mcap:" + path, "--resolution", "160x120", "--no-labels", "--quiet", "--out",
           (dir / "mapped").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("frames 12 "), std::string::npos) << r.out;

  McapReader ours;
  ASSERT_TRUE(ours.open(path).ok());
  EXPECT_EQ(our_count(ours, "/camera/depth"), 12);
  EXPECT_EQ(our_count(ours, "/camera/reference_pose"), 12);  // the synthetic source's ground truth
  std::string why;
  const std::string npm = npm_mcap_summary(path, why);
  if (npm.empty()) GTEST_SKIP() << "the @mcap/core check: " << why;
  for (const char* topic : {"/camera/depth", "/camera/color", "/camera/reference_pose", "/camera/calibration", "/log"})
    EXPECT_EQ(npm_count(npm, topic), our_count(ours, topic)) << topic << ": " << npm;
  EXPECT_NE(npm.find("\"k\":[131.25,0,79.5,"), std::string::npos) << npm;  // the calibration, decoded by Foxglove's reader
}

}  // namespace
}  // namespace ef::app
