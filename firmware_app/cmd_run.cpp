// `edgefusion run`: map a source. Replays it at the working resolution through the surfel SLAM
// (slam/surfel_slam.h) and writes the estimated trajectory, the surfel map and the run statistics.
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "args.h"
#include "commands.h"
#include "core/stage_stats.h"
#include "pipeline/memory_plan.h"
#include "platform/devices/status_panel.h"
#include "core/progress.h"
#include "config_file.h"
#include "pipeline/run_folder.h"
#include "pipeline/run_pipeline.h"
#include "platform/cpu/thread_affinity.h"
#include "platform/devices/service_notify.h"
#include "stop_signal.h"
#include "sources/open_source.h"
#include "synth/synthetic_source.h"

namespace ef::app {

using namespace ef::pipeline;  // the run pipeline, its configuration and memory plan

namespace {

const std::vector<OptionSpec>& run_options() {
  static const std::vector<OptionSpec> specs = [] {
    std::vector<OptionSpec> s = config_override_options();
    s.push_back({"--resume", "DIR",
                 "continue the run in DIR from its newest checkpoint, with its configuration (DIR/config.yaml); "
                 "flags still override keys"});
    return s;
  }();
  return specs;
}

std::string run_help() {
  std::string rooms;
  for (const auto& r : synthetic_room_names()) rooms += (rooms.empty() ? "" : ", ") + r;
  return format_help("edgefusion run --source URI [--config FILE] [--resolution 320x240] [--frames N] --out DIR",
                     "Maps a source and writes into DIR:\n"
                     "  trajectory.txt  estimated camera-to-world poses (TUM format), one per input frame with\n"
                     "                  the source's timestamps; a frame whose tracking was lost keeps the last\n"
                     "                  good pose and is preceded by a line '# lost <timestamp> <reason>';\n"
                     "                  after loop closures it is rewritten at the end with the corrected poses\n"
                     "  map.ply         the surfel map (binary PLY: position, normal, colour, radius, confidence,\n"
                     "                  most likely class and its probability)\n"
                     "  stats.json      frames, seconds, fps, per-stage median/p95 ms, counters (lost frames,\n"
                     "                  surfels created / removed / evicted / refused by the full pool)\n"
                     "The first frame defines the world frame (identity pose).\n"
                     "Labels (SemanticFusion): every N-th frame the CNN's class probabilities multiply into the\n"
                     "surfels it sees (Bayesian update); the optional dense CRF smooths them over the map.\n"
                     "--labels-out renders the map's most likely class into the frame's view, falling back to\n"
                     "the CNN's own prediction where no labelled surfel is seen (class ids 0..13, for\n"
                     "`edgefusion eval labels`) as the map was when the frame arrived; --labels-final-out (a\n"
                     "recording only) reads it again after the run and renders the final map at the estimated\n"
                     "poses into the same frames.\n"
                     "Exit status: 0 the run ended (the source's end, --frames, SIGINT / SIGTERM, the stop button);\n"
                     "1 an error while running (outputs so far written); 2 a usage or configuration error (nothing\n"
                     "started); 3 the live camera vanished (outputs written) or is not there at the start: a service\n"
                     "restarts on it, and with output.resume_interrupted continues the map.\n\n"
                     "Sources: " + std::string(source_uri_help()) + "\nBuilt-in rooms: " + rooms,
                     run_options());
}

// The robot's side of a run, on the mapping thread between frames: SIGINT / SIGTERM and the
// start/stop button end it; the status LED shows tracking / lost; the progress line.
class PanelObserver : public RunObserver {
 public:
  PanelObserver(const char* cmd, GpioLines& gpio, const GpioOptions& options, StageStats& stats, int64_t expected,
                bool progress)
      : cmd_(cmd),
        gpio_(gpio),
        led_(gpio.led.get()),
        button_(gpio.button.get(), options.debounce_ms, /*initially_running=*/true),
        stats_(stats),
        c_signal_(stats.add_counter("stopped_by_signal")),
        c_button_(stats.add_counter("stopped_by_button")),
        progress_("run", expected, progress),
        start_(std::chrono::steady_clock::now()) {}

  void set_led(LedPattern pattern) {
    led_.set_pattern(pattern, now_ms());
    if (!panel_failed_) panel_status(led_.tick(now_ms()));
  }

  bool stop_requested(const RunPipeline& pipeline) override {
    const auto frames = static_cast<long long>(pipeline.mapping().frames());
    if (gpio_.button != nullptr && !panel_failed_) {
      auto pressed = button_.poll(now_ms());
      panel_status(pressed.ok() ? Status::success() : Status(pressed.error()));
      if (pressed.ok() && *pressed && !button_.running()) {
        std::fprintf(stderr, "\n%s: stop button pressed after %lld frames: stopping, writing the outputs\n", cmd_,
                     frames);
        stats_.increment(c_button_);
        return true;
      }
    }
    if (stop_signal_.stop_requested()) {
      std::fprintf(stderr, "\n%s: %s received after %lld frames: stopping, writing the outputs\n", cmd_,
                   stop_signal_.signal_number() == SIGINT ? "SIGINT" : "SIGTERM", frames);
      stats_.increment(c_signal_);
      return true;
    }
    return false;
  }

  void frame_mapped(const RunPipeline& pipeline) override {
    const slam::SlamFrameResult& r = pipeline.mapping().last_result();
    set_led(r.lost ? LedPattern::kLost : LedPattern::kTracking);
    const slam::SurfelSlam& slam = pipeline.slam();
    if (!late_warned_ && pipeline.realtime_late_frames() > 0) {
      late_warned_ = true;
      std::fprintf(stderr,
                   "\n%s: warning: this machine does not keep up with the recording's rate (--realtime): frames go "
                   "out more than %.0f ms late (counted: realtime_frames_late in stats.json)\n",
                   cmd_, FrontStage::kRealtimeLateSeconds * 1000.0);
    }
    if (!preview_warned_ && pipeline.checkpoint_preview_error()) {
      preview_warned_ = true;  // once: a folder that refuses one picture refuses the next ones too
      std::fprintf(stderr, "\n%s: warning: %s: mapping goes on (stats.json counts checkpoint_previews_failed)\n",
                   cmd_, pipeline.checkpoint_preview_error()->message.c_str());
    }
    if (!pool_full_warned_ && slam.pool().full()) {
      // Once: from here on the map keeps the view by forgetting what it left longest ago.
      pool_full_warned_ = true;
      std::fprintf(stderr,
                   "\n%s: warning: the surfel pool is full (%lld surfels, mapping.surfel_capacity) at frame %lld: "
                   "from now on the surfels unseen longest are evicted for new ones (stats.json counts "
                   "surfels_evicted and surfels_refused)\n",
                   cmd_, static_cast<long long>(slam.pool().capacity()),
                   static_cast<long long>(pipeline.mapping().frames() - 1));
    }
    std::snprintf(line_, sizeof line_, "%s, %lld surfels, %lld lost, %lld relocalised, %lld dropped",
                  r.lost ? "LOST" : "tracking", static_cast<long long>(slam.pool().size()),
                  static_cast<long long>(slam.lost_frames()), static_cast<long long>(slam.relocalisations()),
                  static_cast<long long>(pipeline.frames_dropped()));
    progress_.update(pipeline.mapping().frames(), line_);
    // systemd's watchdog: a mapper that stops mapping frames stops proving it is alive. The status
    // line (`systemctl status`) follows at the same pace.
    notifier_.alive(now_ms() * 1000, line_);
  }

  void finish(int64_t frames) { progress_.finish(frames); }
  // The service's notifications (READY, STATUS, WATCHDOG, STOPPING): systemd's view of the run.
  ServiceNotifier& notifier() { return notifier_; }
  void keep_alive() { notifier_.alive(now_ms() * 1000); }
  // SIGINT / SIGTERM received so far (the run's stop was the first; one more stops a later pass).
  int stop_signals() const { return stop_signal_.signals(); }

 private:
  int64_t now_ms() const {
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start_).count();
  }
  // A failing LED or button line is reported once and then left alone: the map matters more.
  void panel_status(const Status& s) {
    if (!s.ok() && !panel_failed_) {
      std::fprintf(stderr, "%s: warning: front panel: %s\n", cmd_, s.error().message.c_str());
      panel_failed_ = true;
    }
  }

  const char* cmd_;
  GpioLines& gpio_;
  StatusLed led_;
  StartStopButton button_;
  StageStats& stats_;
  const int c_signal_, c_button_;
  // SIGINT / SIGTERM from here on: finish the frame in hand, drain, write the outputs and exit 0.
  StopSignalScope stop_signal_;
  Progress progress_;
  ServiceNotifier notifier_;
  bool panel_failed_ = false;
  bool pool_full_warned_ = false;
  bool preview_warned_ = false;
  bool late_warned_ = false;
  std::chrono::steady_clock::time_point start_;
  char line_[128] = {};
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

  // --resume DIR: the run's own configuration, its folder, and its newest checkpoint.
  const bool resume = args->has("--resume");
  if (resume && (args->has("--config") || args->has("--out") || args->has("--overwrite")))
    return report_error(kCmd, error(ErrorCode::kInvalidArgument,
                                    "--resume DIR continues the run in DIR with its own configuration "
                                    "(DIR/config.yaml): it takes no --config, --out or --overwrite"),
                        2);
  const std::string resume_dir = resume ? args->get("--resume") : std::string();
  if (resume && !std::filesystem::exists(std::filesystem::path(resume_dir) / "config.yaml"))
    return report_error(kCmd, error(ErrorCode::kNotFound, "--resume: '" + resume_dir +
                                                              "' has no config.yaml: not the folder of a run"),
                        2);
  auto config_or = resume ? config_from_args(*args, (std::filesystem::path(resume_dir) / "config.yaml").string())
                          : config_from_args(*args);
  if (!config_or.ok()) return report_error(kCmd, config_or.error(), 2);
  RunConfig config = std::move(*config_or);
  std::string continue_dir = resume_dir;
  if (!resume && config.output.resume_interrupted) {
    // A service's restart after a power cut or a lost camera: the interrupted run goes on, in its
    // folder and with its own configuration (as --resume), the command line's flags still applied.
    const InterruptedRun interrupted = find_interrupted_run(config.run);
    if (interrupted.folder.empty()) {
      std::fprintf(stderr, "%s: starting a new run: %s\n", kCmd, interrupted.why.c_str());
    } else {
      std::fprintf(stderr, "%s: continuing the interrupted run %s (it says \"%s\"; checkpoint after frame %lld)\n",
                   kCmd, interrupted.folder.c_str(), interrupted.state.c_str(),
                   static_cast<long long>(interrupted.frames));
      auto own = config_from_args(*args, (std::filesystem::path(interrupted.folder) / "config.yaml").string());
      if (!own.ok()) return report_error(kCmd, own.error(), 2);
      config = std::move(*own);
      continue_dir = interrupted.folder;
    }
  }
  if (!continue_dir.empty()) {
    config.run.out = continue_dir;
    config.output.resume = true;
    config.output.overwrite = false;
  }
  // What can be known wrong without the source (`plan` checks the same: check_and_plan).
  if (Status s = config.validate(); !s.ok()) return report_error(kCmd, s.error(), 2);

  // The front panel, if configured: a missing chip is an error (exit 2) unless gpio.optional.
  auto gpio_or = open_gpio_lines(config.gpio);
  if (!gpio_or.ok()) return report_error(kCmd, gpio_or.error(), 2);
  GpioLines gpio = std::move(*gpio_or);
  // One "warning:" line per line the panel gave (issue 33: no doubled prefix, no blank line).
  for (std::size_t at = 0; at < gpio.warnings.size();) {
    const std::size_t end = std::min(gpio.warnings.find('\n', at), gpio.warnings.size());
    report_warning(kCmd, gpio.warnings.substr(at, end - at));
    at = end + 1;
  }

  auto source_or = open_source(config.run.source);
  if (!source_or.ok()) {
    // A live camera that is not there (unplugged, not yet enumerated after boot) is the vanished
    // camera's case: the service restarts until it is back.
    const auto probe = probe_source(config.run.source);
    const bool absent_camera = probe.ok() && probe->live && source_or.error().code == ErrorCode::kNotFound;
    return report_error(kCmd, source_or.error(), absent_camera ? kExitCameraLost : 1);
  }
  report_warning(kCmd, (*source_or)->info().warning);
  FrameSource& source = **source_or;
  if (source.info().intrinsics_assumed)
    report_warning(kCmd, "the intrinsics are assumed: " + source.info().intrinsics_from +
                             "; if the recording's camera differs, give them in the URI (?fx=..&fy=..&cx=..&cy=.., "
                             "pixels at the recording's size) or, for a TUM folder, in intrinsics.txt");
  const SourceInfo& info = source.info();
  // The source against the configuration, the model and the memory plan, before anything large
  // exists (edgefusion plan prints the plan part by part).
  auto plan = check_and_plan(config, probe_of(source));
  if (!plan.ok()) return report_error(kCmd, plan.error(), 2);
  if (Status s = check_memory_budget(*plan, config); !s.ok()) return report_error(kCmd, s.error(), 2);

  // Everything sized once, before the first frame.
  StageStats stats;
  auto pipeline_or = RunPipeline::create(config, source, stats);
  if (!pipeline_or.ok()) {
    const ErrorCode code = pipeline_or.error().code;
    return report_error(kCmd, pipeline_or.error(), code == ErrorCode::kIoError ? 1 : 2);
  }
  RunPipeline& pipeline = **pipeline_or;
  report_warning(kCmd, pipeline.resume_warning());
  if (pipeline.resumed())
    std::fprintf(stderr, "%s: resuming %s after frame %lld (checkpoint of %.1f s of mapping)\n", kCmd,
                 pipeline.out_folder().c_str(), static_cast<long long>(pipeline.resumed()->frames),
                 pipeline.resumed()->seconds);
  int64_t expected = info.frame_count;
  if (config.run.frames > 0 && (expected < 0 || config.run.frames < expected)) expected = config.run.frames;
  PanelObserver panel(kCmd, gpio, config.gpio, stats, expected, config.run.progress);

  const slam::SurfelSlam& slam = pipeline.slam();
  std::fprintf(stderr,
               "%s: source %s (%dx%d, %s frames), working resolution %dx%d (fx %.1f), pool %lld surfels (%.0f MB)\n",
               kCmd, config.run.source.c_str(), info.intrinsics.width, info.intrinsics.height,
               info.frame_count >= 0 ? std::to_string(info.frame_count).c_str() : "unknown", config.run.resolution.width,
               config.run.resolution.height, slam.predictor().intrinsics().fx,
               static_cast<long long>(config.mapping.pool.capacity),
               static_cast<double>(slam.pool_bytes()) / 1e6);
  std::fprintf(stderr, "%s: intrinsics fx %.2f fy %.2f cx %.2f cy %.2f at %dx%d, from %s\n", kCmd, info.intrinsics.fx,
               info.intrinsics.fy, info.intrinsics.cx, info.intrinsics.cy, info.intrinsics.width,
               info.intrinsics.height, info.intrinsics_from.empty() ? "the device" : info.intrinsics_from.c_str());
  const int threads = config.pipeline.threads;
  const int slots = config.pipeline.slots();
  const char* layout = threads == 1   ? "front, CNN and mapping in turn on one thread"
                       : threads == 2 ? "front + CNN beside mapping"
                                             : "front, CNN and mapping each on its own";
  std::fprintf(stderr, "%s: %d thread%s (%s), %d frame slot%s of %.1f MB%s\n", kCmd, threads,
               threads == 1 ? "" : "s", layout, slots, slots == 1 ? "" : "s",
               static_cast<double>(pipeline.slot_bytes()) / 1e6,
               info.live ? (", capture thread with " + std::to_string(config.pipeline.capture_slots) + " slots").c_str() : "");
  if (pipeline.config().pipeline.pinning == "auto" || pipeline.config().pipeline.pinning_text() != "none")
    std::fprintf(stderr, "%s: threads pinned to cores: %s%s\n", kCmd, pipeline.config().pipeline.pinning_text().c_str(),
                 pipeline.config().pipeline.pinning == "auto"
                     ? (" (pipeline.pinning auto, of " + cores_text(usable_cpu_cores()) + ")").c_str()
                     : "");
  if (pipeline.semantics() != nullptr)
    std::fprintf(stderr, "%s: %s\n", kCmd, pipeline.semantics()->describe().c_str());
  else
    std::fprintf(stderr, "%s: labels off (geometry only)\n", kCmd);
  if (pipeline.out_folder() != config.run.out) std::fprintf(stderr, "%s: run folder %s\n", kCmd, pipeline.out_folder().c_str());
  std::fprintf(stderr, "%s: memory plan %.1f MB of the %lld MB budget (`edgefusion plan` lists the parts)\n", kCmd,
               static_cast<double>(plan->total_bytes) / 1e6, static_cast<long long>(config.memory.budget_mb));

  panel.set_led(LedPattern::kTracking);
  panel.notifier().ready("mapping " + config.run.source + " into " + pipeline.out_folder());
  const RunOutcome outcome = pipeline.run(panel);
  panel.finish(outcome.frames);
  int exit_code = 0;
  if (outcome.error) {
    // Keep what was already accepted: the trajectory, map and statistics so far are written below.
    report_error(kCmd, *outcome.error, 1);
    exit_code = 1;
  } else if (outcome.camera_lost) {
    exit_code = kExitCameraLost;  // outputs written below; a service restarts on it
  }
  // Writing the outputs: the slow blink until they are on disk, then off.
  panel.set_led(LedPattern::kLogging);
  panel.notifier().stopping("writing the outputs of " + std::to_string(outcome.frames) + " frames");
  const OutputFiles files = pipeline.write_outputs(outcome);
  for (const Error& e : files.errors) report_error(kCmd, e, 1);
  if (!files.errors.empty()) exit_code = 1;
  panel.set_led(LedPattern::kOff);

  std::printf("frames %lld in %.2f s (%.1f fps), lost %lld, relocalised %lld, surfels %lld, keyframes %d\n",
              static_cast<long long>(outcome.frames), outcome.seconds,
              outcome.seconds > 0 ? static_cast<double>(outcome.frames) / outcome.seconds : 0.0,
              static_cast<long long>(slam.lost_frames()), static_cast<long long>(slam.relocalisations()),
              static_cast<long long>(slam.pool().size()), static_cast<int>(slam.keyframes().size()));
  const slam::SurfelPoolCounters& pool = slam.pool().counters();
  if (pool.evicted + pool.refused > 0)
    std::printf("surfel pool full (%lld surfels, mapping.surfel_capacity): %llu evicted (unseen longest), %llu "
                "refused\n",
                static_cast<long long>(slam.pool().capacity()), static_cast<unsigned long long>(pool.evicted),
                static_cast<unsigned long long>(pool.refused));
  if (config.run.realtime && !info.live)
    std::printf("realtime: %llu of %lld frames late by more than %.0f ms (at most %.2f s behind the recording)\n",
                static_cast<unsigned long long>(pipeline.realtime_late_frames()), static_cast<long long>(outcome.frames),
                FrontStage::kRealtimeLateSeconds * 1000.0, static_cast<double>(pipeline.realtime_max_late_ms()) / 1000.0);
  if (files.wrote_trajectory && files.trajectory_corrected + files.trajectory_kept > 0)
    std::printf("trajectory: %s (%lld poses corrected by loop closure, %lld older ones as tracked)\n",
                files.trajectory.c_str(), static_cast<long long>(files.trajectory_corrected),
                static_cast<long long>(files.trajectory_kept));
  else if (files.wrote_trajectory)
    std::printf("trajectory: %s\n", files.trajectory.c_str());
  if (files.wrote_map) std::printf("map: %s\n", files.map.c_str());
  if (files.wrote_preview) std::printf("preview: %s\n", files.preview.c_str());
  if (files.wrote_report) std::printf("report: %s\n", files.report.c_str());
  if (files.wrote_stats) std::printf("stats: %s\n", files.stats.c_str());
  if (!config.labels.out.empty()) {
    const int written = stats.counter_id("label_images_written");
    std::printf("labels: %s (%llu images, every %d frames; in the palette: %s)\n", config.labels.out.c_str(),
                static_cast<unsigned long long>(written >= 0 ? stats.counter(written) : 0), config.labels.out_every,
                color_label_folder(config.labels.out).c_str());
  }
  if (files.wrote_log)
    std::printf("log: %s (%llu frames)\n", files.log.c_str(), static_cast<unsigned long long>(files.log_frames));
  // The final map's labels in the recording's frames: a second reading, after the outputs are safe.
  if (!config.labels.final_out.empty() && outcome.frames > 0) {
    std::fprintf(stderr, "%s: rendering the final map's labels into %s, every %d frames\n", kCmd,
                 config.run.source.c_str(), config.labels.out_every);
    auto replay = open_source(config.run.source);
    // A signal during this pass (a second one if the run itself was stopped by one) stops it now:
    // the images so far are whole, the outputs above are already safe.
    const int signals_before = panel.stop_signals();
    const auto stop = [&panel, signals_before] {
      panel.keep_alive();
      return panel.stop_signals() > signals_before;
    };
    auto counts =
        replay.ok() ? pipeline.render_final_labels(**replay, stop) : Result<FinalLabelCounts>(replay.error());
    if (!counts.ok()) {
      report_error(kCmd, counts.error(), 1);
      exit_code = 1;
    } else {
      std::printf("final labels: %lld images in %s (%lld of lost frames: the CNN's labels; %lld frames not mapped)%s\n",
                  static_cast<long long>(counts->images_written), config.labels.final_out.c_str(),
                  static_cast<long long>(counts->from_cnn_only), static_cast<long long>(counts->not_mapped),
                  counts->stopped ? "; stopped by a signal" : "");
    }
  }
  if (exit_code == kExitCameraLost)
    std::fprintf(stderr, "%s: the camera vanished after %lld frames: exit status %d (the service restarts)\n", kCmd,
                 static_cast<long long>(outcome.frames), kExitCameraLost);
  return exit_code;
}

const std::vector<OptionSpec>& run_command_options() { return run_options(); }

}  // namespace ef::app
