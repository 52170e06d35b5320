// `edgefusion run`: map a source. Replays it at the working resolution through the surfel SLAM
// (slam/surfel_slam.h) and writes the estimated trajectory, the surfel map and the run statistics.
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "args.h"
#include "commands.h"
#include "core/frame.h"
#include "core/stage_stats.h"
#include "io/frame_resample.h"
#include "io/ply_writer.h"
#include "io/stats_json.h"
#include "capture_thread.h"
#include "io/trajectory_io.h"
#include "memory_plan.h"
#include "platform/devices/status_panel.h"
#include "progress.h"
#include "run_config.h"
#include "run_semantics.h"
#include "stop_signal.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"
#include "synth/synthetic_source.h"

namespace ef::app {

namespace {

// Frame slots between the capture thread of a live camera and the mapper: one being written, one
// being read, two waiting (about 70 ms at 30 Hz) before the oldest is dropped.
constexpr int kCaptureSlots = 4;

const std::vector<OptionSpec>& run_options() { return config_override_options(); }

std::string run_help() {
  std::string rooms;
  for (const auto& r : synthetic_room_names()) rooms += (rooms.empty() ? "" : ", ") + r;
  return format_help("edgefusion run --source URI [--config FILE] [--resolution 320x240] [--frames N] --out DIR",
                     "Maps a source and writes into DIR:\n"
                     "  trajectory.txt  estimated camera-to-world poses (TUM format), one per input frame with\n"
                     "                  the source's timestamps; a frame whose tracking was lost keeps the last\n"
                     "                  good pose and is preceded by a line '# lost <timestamp> <reason>'\n"
                     "  map.ply         the surfel map (binary PLY: position, normal, colour, radius, confidence,\n"
                     "                  most likely class and its probability)\n"
                     "  stats.json      frames, seconds, fps, per-stage median/p95 ms, counters (lost frames,\n"
                     "                  surfels created / removed / evicted / refused by the full pool)\n"
                     "The first frame defines the world frame (identity pose).\n"
                     "Labels (SemanticFusion): every N-th frame the CNN's class probabilities multiply into the\n"
                     "surfels it sees (Bayesian update); the optional dense CRF smooths them over the map.\n"
                     "--labels-out renders the map's most likely class into the frame's view, falling back to\n"
                     "the CNN's own prediction where no labelled surfel is seen (class ids 0..13, for\n"
                     "`edgefusion eval labels`).\n\n"
                     "Sources: " + std::string(source_uri_help()) + "\nBuilt-in rooms: " + rooms,
                     run_options());
}

// Counters written to stats.json, registered once at start-up.
struct RunCounters {
  int frames, frames_with_pose, frames_with_labels, lost_frames, fused_frames, surfels_created, surfels_removed,
      surfels_evicted, surfels_refused, camera_lost, corrupt_frames_dropped, frames_dropped_overload, stopped_by_signal,
      stopped_by_button;
};

// Stage ids of the SLAM steps in StageStats.
struct SlamStages {
  int preprocess, track, fuse, predict;
};

slam::SurfelSlamOptions slam_options(const RunConfig& config) {
  slam::SurfelSlamOptions o;
  o.pool.capacity = config.surfel_capacity;
  o.tracker.icp_weight = config.icp_weight;
  o.tracker.rgb_weight = config.rgb_weight;
  o.preprocess.depth_cutoff_m = config.depth_cutoff_m;
  return o;
}

}  // namespace

int cmd_run(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion run";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", run_help().c_str());
    return 0;
  }
  auto args = parse_args(kCmd, run_options(), 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);

  auto config_or = config_from_args(*args);
  if (!config_or.ok()) return report_error(kCmd, config_or.error(), 2);
  RunConfig config = std::move(*config_or);
  if (!config.labels && (!config.labels_out.empty() || config.crf_every > 0 || config.crf_final))
    return report_error(kCmd, error(ErrorCode::kInvalidArgument,
                                    "--labels-out and the CRF need labels: drop --no-labels (or 'labels: false')"),
                        2);
  if (config.out_dir.empty())
    return report_error(kCmd, error(ErrorCode::kInvalidArgument, "missing --out DIR (or 'out:' in --config)"), 2);

  // The memory plan before anything large exists (edgefusion plan prints it part by part).
  if (Status s = check_memory_budget(config); !s.ok()) return report_error(kCmd, s.error(), 2);

  // The front panel, if configured: a missing chip is an error (exit 2) unless gpio.optional.
  auto gpio_or = open_gpio_lines(config.gpio);
  if (!gpio_or.ok()) return report_error(kCmd, gpio_or.error(), 2);
  GpioLines gpio = std::move(*gpio_or);
  if (!gpio.warnings.empty()) std::fprintf(stderr, "%s: warning: %s\n", kCmd, gpio.warnings.c_str());
  StatusLed led(gpio.led.get());
  StartStopButton button(gpio.button.get(), config.gpio.debounce_ms, /*initially_running=*/true);
  const auto panel_clock_start = std::chrono::steady_clock::now();
  const auto panel_now_ms = [&] {
    return static_cast<int64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                    std::chrono::steady_clock::now() - panel_clock_start)
                                    .count());
  };
  // A failing LED or button line is reported once and then left alone: the map matters more.
  bool panel_failed = false;
  const auto panel_status = [&](const Status& s) {
    if (!s.ok() && !panel_failed) {
      std::fprintf(stderr, "%s: warning: front panel: %s\n", kCmd, s.error().message.c_str());
      panel_failed = true;
    }
  };

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
  const std::string map_path = (std::filesystem::path(config.out_dir) / "map.ply").string();
  const std::string stats_path = (std::filesystem::path(config.out_dir) / "stats.json").string();

  // Everything sized once, before the first frame.
  Frame input, working;
  input.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  working.allocate(config.width, config.height, info.has_labels);
  const Intrinsics working_k = info.intrinsics.scaled_to(config.width, config.height);
  int64_t expected = info.frame_count;
  if (config.max_frames > 0 && (expected < 0 || config.max_frames < expected)) expected = config.max_frames;

  auto slam_or = slam::SurfelSlam::create(working_k, slam_options(config));
  if (!slam_or.ok()) return report_error(kCmd, slam_or.error(), 2);
  slam::SurfelSlam& slam = *slam_or;

  StageStats stats;
  std::unique_ptr<RunSemantics> semantics;
  if (config.labels) {
    auto sem = RunSemantics::create(config, working_k, stats);
    if (!sem.ok()) return report_error(kCmd, sem.error(), 2);
    semantics = std::move(*sem);
  }
  const int st_source = stats.add_stage("source");
  const int st_resample = stats.add_stage("resample");
  const SlamStages st{stats.add_stage("preprocess"), stats.add_stage("track"), stats.add_stage("fuse"),
                      stats.add_stage("predict")};
  const int st_slam = stats.add_stage("slam_total");
  const int st_output = stats.add_stage("output");
  const RunCounters c{stats.add_counter("frames"),          stats.add_counter("frames_with_pose"),
                      stats.add_counter("frames_with_labels"), stats.add_counter("lost_frames"),
                      stats.add_counter("fused_frames"),    stats.add_counter("surfels_created"),
                      stats.add_counter("surfels_removed"), stats.add_counter("surfels_evicted"),
                      stats.add_counter("surfels_refused"), stats.add_counter("camera_lost"),
                      stats.add_counter("corrupt_frames_dropped"), stats.add_counter("frames_dropped_overload"),
                      stats.add_counter("stopped_by_signal"),
                      stats.add_counter("stopped_by_button")};

  // SIGINT / SIGTERM from here on: finish the frame in hand, write everything below and exit 0.
  StopSignalScope stop_signal;
  TumTrajectoryWriter trajectory;
  if (Status s = trajectory.open(trajectory_path); !s.ok()) return report_error(kCmd, s.error(), 1);

  std::fprintf(stderr, "%s: source %s (%dx%d, %s frames), working resolution %dx%d (fx %.1f), pool %lld surfels (%.0f MB)\n",
               kCmd, config.source.c_str(), info.intrinsics.width, info.intrinsics.height,
               info.frame_count >= 0 ? std::to_string(info.frame_count).c_str() : "unknown", config.width,
               config.height, working_k.fx, static_cast<long long>(config.surfel_capacity),
               static_cast<double>(slam.pool_bytes()) / 1e6);
  if (semantics != nullptr)
    std::fprintf(stderr, "%s: %s (%.1f MB)\n", kCmd, semantics->describe().c_str(),
                 static_cast<double>(semantics->bytes()) / 1e6);
  else
    std::fprintf(stderr, "%s: labels off (geometry only)\n", kCmd);

  Progress progress("run", expected, config.progress);
  const auto start = std::chrono::steady_clock::now();
  int64_t frames = 0;
  int exit_code = 0;
  slam::SlamFrameResult result;
  // Live cameras are read on their own thread into a ring of 4 slots (drop-oldest when the mapper
  // falls behind); recordings are read here and wait for the mapper.
  std::unique_ptr<CaptureThread> capture;
  if (info.live) {
    capture = std::make_unique<CaptureThread>(source, kCaptureSlots);
    capture->start();
  }
  char line[128];
  int64_t dropped_frames = 0;  // corrupt frames of a live camera, skipped
  std::chrono::steady_clock::time_point replay_wall_start;  // --realtime: wall time of the first frame
  double replay_t0 = 0;                                      // and its timestamp, seconds
  led.set_pattern(LedPattern::kTracking, panel_now_ms());
  while (config.max_frames < 0 || frames < config.max_frames) {
    if (gpio.button != nullptr && !panel_failed) {
      auto pressed = button.poll(panel_now_ms());
      panel_status(pressed.ok() ? Status::success() : Status(pressed.error()));
      if (pressed.ok() && *pressed && !button.running()) {
        std::fprintf(stderr, "\n%s: stop button pressed after %lld frames: stopping, writing the outputs\n", kCmd,
                     static_cast<long long>(frames));
        stats.increment(c.stopped_by_button);
        break;
      }
    }
    if (stop_signal.stop_requested()) {
      std::fprintf(stderr, "\n%s: %s received after %lld frames: stopping, writing the outputs\n", kCmd,
                   stop_signal.signal_number() == SIGINT ? "SIGINT" : "SIGTERM", static_cast<long long>(frames));
      stats.increment(c.stopped_by_signal);
      break;
    }
    ScopedStageTimer t_source(stats, st_source);
    // A live camera is read by the capture thread; a recording here, waiting for the mapper.
    CapturedFrame* slot = nullptr;
    std::optional<Error> source_error;
    bool have_frame = false;
    if (capture != nullptr) {
      slot = capture->acquire(std::chrono::milliseconds(200));
      if (slot == nullptr) {  // nothing captured yet: look at the stop requests again
        t_source.cancel();
        continue;
      }
      if (slot->end) source_error = slot->error;
      have_frame = !slot->end;
    } else {
      auto got = source.next(input);
      if (!got.ok()) source_error = got.error();
      have_frame = got.ok() && *got;
    }
    if (!have_frame) {
      t_source.cancel();  // only delivered frames count in the stage's timing
      if (slot != nullptr) capture->release();
    }
    if (source_error) {
      if (is_camera_lost(info, *source_error)) {
        // A camera that vanished ends capture like a stop: what was mapped so far is written below.
        std::fprintf(stderr, "%s: %s; capture stopped, writing the outputs of %lld frames\n", kCmd,
                     source_error->message.c_str(), static_cast<long long>(frames));
        stats.increment(c.camera_lost);
        break;
      }
      if (info.live && source_error->code == ErrorCode::kCorruptData) {
        // One bad frame of a live camera: dropped and counted, capture goes on.
        stats.increment(c.corrupt_frames_dropped);
        ++dropped_frames;
        continue;
      }
      // Keep what was already accepted: the trajectory, map and statistics so far are written below.
      report_error(kCmd, *source_error, 1);
      exit_code = 1;
      break;
    }
    if (!have_frame) break;
    const Frame& captured = slot != nullptr ? slot->frame : input;
    t_source.stop();
    if (config.realtime && !info.live) {
      // Recorded speed: frame k is processed no earlier than (t_k - t_0) after the first one.
      if (frames == 0) {
        replay_wall_start = std::chrono::steady_clock::now();
        replay_t0 = captured.timestamp;
      } else {
        std::this_thread::sleep_until(replay_wall_start +
                                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                          std::chrono::duration<double>(captured.timestamp - replay_t0)));
      }
    }

    {
      ScopedStageTimer t(stats, st_resample);
      resample_frame(captured, working);
    }
    if (slot != nullptr) capture->release();  // the slot is free for the camera again
    if (Status s = slam.process(working, &result); !s.ok()) {
      report_error(kCmd, s.error(), 1);
      exit_code = 1;
      break;
    }
    stats.record_ms(st.preprocess, result.timings.preprocess_ms);
    if (frames > 0) stats.record_ms(st.track, result.timings.track_ms);  // frame 0 has nothing to track
    if (result.fused) stats.record_ms(st.fuse, result.timings.fuse_ms);
    stats.record_ms(st.predict, result.timings.predict_ms);
    stats.record_ms(st_slam, result.timings.total_ms);
    if (semantics != nullptr) {
      if (Status s = semantics->on_frame(frames, working, result, slam); !s.ok()) {
        report_error(kCmd, s.error(), 1);
        exit_code = 1;
        break;
      }
    }
    {
      ScopedStageTimer t(stats, st_output);
      Status s;
      if (result.lost) {
        std::snprintf(line, sizeof line, "lost %.6f %s", working.timestamp,
                      slam::track_lost_reason_name(result.track.reason));
        s = trajectory.write_comment(line);
      }
      if (s.ok()) s = trajectory.write(working.timestamp, result.T_world_cam);
      if (!s.ok()) {
        report_error(kCmd, s.error(), 1);
        exit_code = 1;
        break;
      }
    }
    stats.increment(c.frames);
    stats.increment(c.frames_with_pose, working.has_pose ? 1 : 0);
    stats.increment(c.frames_with_labels, working.has_labels ? 1 : 0);
    stats.increment(c.lost_frames, result.lost ? 1 : 0);
    stats.increment(c.fused_frames, result.fused ? 1 : 0);
    ++frames;
    led.set_pattern(result.lost ? LedPattern::kLost : LedPattern::kTracking, panel_now_ms());
    if (!panel_failed) panel_status(led.tick(panel_now_ms()));
    std::snprintf(line, sizeof line, "%s, %lld surfels, %lld lost, %lld dropped", result.lost ? "LOST" : "tracking",
                  static_cast<long long>(slam.pool().size()), static_cast<long long>(slam.lost_frames()),
                  static_cast<long long>(dropped_frames + (capture != nullptr ? static_cast<int64_t>(
                                                                        capture->dropped() + capture->corrupt_dropped())
                                                                  : 0)));
    progress.update(frames, line);
  }
  if (capture != nullptr) {
    capture->stop();
    stats.set_counter(c.frames_dropped_overload, capture->dropped());
    stats.increment(c.corrupt_frames_dropped, capture->corrupt_dropped());
  }
  progress.finish(frames);
  // Writing the outputs: the slow blink until they are on disk, then off.
  led.set_pattern(LedPattern::kLogging, panel_now_ms());
  if (!panel_failed) panel_status(led.tick(panel_now_ms()));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const slam::SurfelPoolCounters& pc = slam.pool().counters();
  stats.set_counter(c.surfels_created, pc.created);
  stats.set_counter(c.surfels_removed, pc.removed);
  stats.set_counter(c.surfels_evicted, pc.evicted);
  stats.set_counter(c.surfels_refused, pc.refused);

  bool wrote_trajectory = false, wrote_map = false;
  if (Status s = trajectory.close(); !s.ok()) {
    report_error(kCmd, s.error(), 1);
    exit_code = 1;
  } else {
    wrote_trajectory = true;
  }
  if (semantics != nullptr) {
    if (Status s = semantics->finish(slam); !s.ok()) {
      report_error(kCmd, s.error(), 1);
      exit_code = 1;
    }
  }
  if (config.write_map) {
    const std::string comment = "edgefusion map of " + config.source + ", " + std::to_string(frames) + " frames";
    SurfelCloudView cloud = slam::surfel_cloud_view(slam.pool());
    if (semantics != nullptr) semantics->add_label_columns(slam.pool(), cloud);
    if (Status s = write_surfel_ply(map_path, cloud, comment); !s.ok()) {
      report_error(kCmd, s.error(), 1);
      exit_code = 1;
    } else {
      wrote_map = true;
    }
  }
  const std::vector<StatsExtraField> extra = {
      {"width", static_cast<double>(config.width)},
      {"height", static_cast<double>(config.height)},
      {"surfels", static_cast<double>(slam.pool().size())},
      {"surfel_capacity", static_cast<double>(slam.pool().capacity())},
      {"surfel_pool_bytes", static_cast<double>(slam.pool_bytes())},
      {"bytes_per_surfel", static_cast<double>(slam::SurfelPool::kBytesPerSurfel)}};
  if (Status s = write_stats_json(stats_path, stats, static_cast<uint64_t>(frames), seconds, extra); !s.ok()) {
    report_error(kCmd, s.error(), 1);
    exit_code = 1;
  }

  led.set_pattern(LedPattern::kOff, panel_now_ms());
  if (!panel_failed) panel_status(led.tick(panel_now_ms()));
  std::printf("frames %lld in %.2f s (%.1f fps), lost %lld, surfels %lld\n", static_cast<long long>(frames),
              seconds, seconds > 0 ? static_cast<double>(frames) / seconds : 0.0,
              static_cast<long long>(slam.lost_frames()), static_cast<long long>(slam.pool().size()));
  if (wrote_trajectory) std::printf("trajectory: %s\n", trajectory_path.c_str());
  if (wrote_map) std::printf("map: %s\n", map_path.c_str());
  std::printf("stats: %s\n", stats_path.c_str());
  return exit_code;
}

}  // namespace ef::app
