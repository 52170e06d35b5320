// `edgefusion run`: map a source. At this stage (no tracker yet) it replays the source at the
// working resolution and writes the source's reference trajectory and the run statistics.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "args.h"
#include "commands.h"
#include "core/frame.h"
#include "core/stage_stats.h"
#include "io/frame_resample.h"
#include "io/stats_json.h"
#include "io/trajectory_io.h"
#include "progress.h"
#include "run_config.h"
#include "sources/open_source.h"
#include "synth/synthetic_source.h"

namespace ef::app {

namespace {

const std::vector<OptionSpec>& run_options() {
  static const std::vector<OptionSpec> specs = {
      {"--source", "URI", "frame source; default synthetic: (see below)"},
      {"--config", "FILE", "configuration file (key: value lines; keys source, resolution, frames, out, progress)"},
      {"--resolution", "WxH", "working resolution for tracking and label fusion, pixels; default 320x240"},
      {"--frames", "N", "process at most N frames; default all the source has"},
      {"--out", "DIR", "output folder, created if missing; required here or in the configuration"},
      {"--quiet", "", "no progress line"},
  };
  return specs;
}

std::string run_help() {
  std::string rooms;
  for (const auto& r : synthetic_room_names()) rooms += (rooms.empty() ? "" : ", ") + r;
  return format_help("edgefusion run --source URI [--config FILE] [--resolution 320x240] [--frames N] --out DIR",
                     "Maps a source and writes into DIR: trajectory.txt (TUM format, camera to world), map.ply\n"
                     "(once a map exists) and stats.json (frames, seconds, fps, per-stage median/p95 ms,\n"
                     "counters). Until the tracker lands, the trajectory is the source's reference poses.\n\n"
                     "Sources: " + std::string(source_uri_help()) + "\nBuilt-in rooms: " + rooms,
                     run_options());
}

// Counters written to stats.json, registered once at start-up.
struct RunCounters {
  int frames, frames_with_pose, frames_with_labels, valid_depth_pixels, depth_pixels;
};

}  // namespace

int cmd_run(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion run";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", run_help().c_str());
    return 0;
  }
  auto args = parse_args(kCmd, run_options(), 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);

  RunConfig config;
  if (args->has("--config")) {
    if (Status s = apply_config_file(args->get("--config"), config); !s.ok()) return report_error(kCmd, s.error(), 2);
  }
  for (const char* key : {"source", "resolution", "frames", "out"}) {
    const std::string opt = std::string("--") + key;
    if (!args->has(opt)) continue;
    if (Status s = apply_config_value(key, args->get(opt), "option " + opt, config); !s.ok())
      return report_error(kCmd, s.error(), 2);
  }
  if (args->has("--quiet")) config.progress = false;
  if (config.out_dir.empty())
    return report_error(kCmd, error(ErrorCode::kInvalidArgument, "missing --out DIR (or 'out:' in --config)"), 2);

  auto source_or = open_source(config.source);
  if (!source_or.ok()) return report_error(kCmd, source_or.error(), 1);
  FrameSource& source = **source_or;
  const SourceInfo& info = source.info();

  std::error_code ec;
  std::filesystem::create_directories(config.out_dir, ec);
  if (ec)
    return report_error(kCmd, error(ErrorCode::kIoError, "cannot create output folder '" + config.out_dir +
                                                             "': " + ec.message()), 1);
  const std::string trajectory_path = (std::filesystem::path(config.out_dir) / "trajectory.txt").string();
  const std::string stats_path = (std::filesystem::path(config.out_dir) / "stats.json").string();

  // Everything sized once, before the first frame.
  Frame input, working;
  input.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  working.allocate(config.width, config.height, info.has_labels);
  const Intrinsics working_k = info.intrinsics.scaled_to(config.width, config.height);
  int64_t expected = info.frame_count;
  if (config.max_frames > 0 && (expected < 0 || config.max_frames < expected)) expected = config.max_frames;

  StageStats stats;
  const int st_source = stats.add_stage("source");
  const int st_resample = stats.add_stage("resample");
  const int st_output = stats.add_stage("output");
  RunCounters c{stats.add_counter("frames"), stats.add_counter("frames_with_pose"),
                stats.add_counter("frames_with_labels"), stats.add_counter("valid_depth_pixels"),
                stats.add_counter("depth_pixels")};

  TumTrajectoryWriter trajectory;
  if (info.has_pose) {
    if (Status s = trajectory.open(trajectory_path); !s.ok()) return report_error(kCmd, s.error(), 1);
  }

  std::fprintf(stderr, "%s: source %s (%dx%d, %s frames), working resolution %dx%d (fx %.1f)\n", kCmd,
               config.source.c_str(), info.intrinsics.width, info.intrinsics.height,
               info.frame_count >= 0 ? std::to_string(info.frame_count).c_str() : "unknown", config.width,
               config.height, working_k.fx);

  Progress progress("run", expected, config.progress);
  const auto start = std::chrono::steady_clock::now();
  int64_t frames = 0;
  int exit_code = 0;
  while (config.max_frames < 0 || frames < config.max_frames) {
    ScopedStageTimer t_source(stats, st_source);
    auto got = source.next(input);
    if (!got.ok() || !*got) t_source.cancel();  // only delivered frames count in the stage's timing
    if (!got.ok()) {
      // Keep what was already accepted: the trajectory and the statistics so far are written below.
      report_error(kCmd, got.error(), 1);
      exit_code = 1;
      break;
    }
    if (!*got) break;
    t_source.stop();

    {
      ScopedStageTimer t(stats, st_resample);
      resample_frame(input, working);
    }
    {
      ScopedStageTimer t(stats, st_output);
      if (working.has_pose && trajectory.is_open()) {
        if (Status s = trajectory.write(working.timestamp, working.T_wc); !s.ok()) {
          report_error(kCmd, s.error(), 1);
          exit_code = 1;
          break;
        }
      }
    }
    uint64_t valid = 0;
    for (std::size_t i = 0; i < working.depth.size(); ++i) valid += working.depth.data()[i] > 0;
    stats.increment(c.frames);
    stats.increment(c.frames_with_pose, working.has_pose ? 1 : 0);
    stats.increment(c.frames_with_labels, working.has_labels ? 1 : 0);
    stats.increment(c.valid_depth_pixels, valid);
    stats.increment(c.depth_pixels, working.depth.size());
    ++frames;
    progress.update(frames);
  }
  progress.finish(frames);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  bool wrote_trajectory = false;
  if (trajectory.is_open()) {
    if (Status s = trajectory.close(); !s.ok()) {
      report_error(kCmd, s.error(), 1);
      exit_code = 1;
    } else {
      wrote_trajectory = true;
    }
  }
  const std::vector<StatsExtraField> extra = {{"width", static_cast<double>(config.width)},
                                              {"height", static_cast<double>(config.height)}};
  if (Status s = write_stats_json(stats_path, stats, static_cast<uint64_t>(frames), seconds, extra); !s.ok()) {
    report_error(kCmd, s.error(), 1);
    exit_code = 1;
  }

  std::printf("frames %lld in %.2f s (%.1f fps)\n", static_cast<long long>(frames), seconds,
              seconds > 0 ? static_cast<double>(frames) / seconds : 0.0);
  if (wrote_trajectory) std::printf("trajectory: %s\n", trajectory_path.c_str());
  else std::printf("trajectory: none (the source has no poses and no tracker is built yet)\n");
  std::printf("map: none yet (surfel fusion lands with the SLAM issue)\n");
  std::printf("stats: %s\n", stats_path.c_str());
  return exit_code;
}

}  // namespace ef::app
