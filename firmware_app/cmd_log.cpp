// `edgefusion log`: the low-power logging mode (issue 29). A robot that maps later, or elsewhere,
// records what its camera sees into an MCAP field log (io/mcap_log.h) and does nothing else: no
// tracking, no fusion, no CNN. A recording is read and written on one thread; a live camera is read
// on a capture thread into a ring (pipeline/capture_thread.h), so that a slow write (a chunk synced
// to an SD card) never holds the camera up: a frame the full ring could not take is dropped and
// counted, and the count is printed. `run --source mcap:FILE` maps the log afterwards.
#include <sys/resource.h>
#include <sys/stat.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "args.h"
#include "commands.h"
#include "core/frame.h"
#include "core/progress.h"
#include "io/mcap_log.h"
#include "pipeline/capture_thread.h"
#include "sources/open_source.h"
#include "stop_signal.h"

namespace ef::app {

namespace {

const std::vector<OptionSpec> kLogOptions = {
    {"--source", "URI", "frame source (see edgefusion run --help): a camera, or a recording", true},
    {"--out", "FILE", "the MCAP log to write", true},
    {"--frames", "N", "log at most N frames; default all (a camera: until stopped)"},
    {"--realtime", "", "replay a recording at its recorded rate (what a camera would deliver)"},
    {"--log-depth", "png|raw", "depth: png (16-bit, lossless) or raw (no encoding, 3x the bytes); default png"},
    {"--log-color", "jpeg|png|raw|none", "colour; default jpeg"},
    {"--color-every", "N", "colour of every N-th frame only; default 1"},
    {"--jpeg-quality", "Q", "1..100; default 90"},
    {"--chunk-seconds", "S", "what a power cut may lose at most, seconds; default 1"},
    {"--overwrite", "", "replace an existing FILE (otherwise refused)"},
    {"--quiet", "", "no progress line"},
};

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace

int cmd_log(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion log";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", format_help("edgefusion log --source URI --out FILE.mcap [--realtime] [--frames N]",
                                  "Records a field log and nothing else: the low-power mode for a robot that maps\n"
                                  "later (no tracking, fusion or CNN; one thread). The log holds depth (lossless),\n"
                                  "colour, the calibration and the source's reference poses, in chunks written\n"
                                  "every --chunk-seconds, so a kill or a power cut loses at most the last chunk.\n"
                                  "Map it later with: edgefusion run --source mcap:FILE.mcap --out DIR\n"
                                  "SIGINT / SIGTERM stop after the frame in hand and close the log (exit 0).\n"
                                  "At the end it prints the frames, the rate and the CPU time per frame.\n\n"
                                  "Sources: " + std::string(source_uri_help()),
                                  kLogOptions).c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kLogOptions, 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto max_frames = args->get_int("--frames", -1, 1, INT64_MAX);
  if (!max_frames.ok()) return report_error(kCmd, max_frames.error(), 2);
  McapLogOptions options;
  options.depth = args->get("--log-depth", options.depth);
  options.color = args->get("--log-color", options.color);
  auto every = args->get_int("--color-every", options.color_every, 1, 1000000);
  if (!every.ok()) return report_error(kCmd, every.error(), 2);
  options.color_every = *every;
  auto quality = args->get_int("--jpeg-quality", options.jpeg_quality, 1, 100);
  if (!quality.ok()) return report_error(kCmd, quality.error(), 2);
  options.jpeg_quality = *quality;
  auto chunk = args->get_double("--chunk-seconds", options.chunk_seconds, 0.01, 3600);
  if (!chunk.ok()) return report_error(kCmd, chunk.error(), 2);
  options.chunk_seconds = *chunk;
  if (Status s = options.validate(); !s.ok()) return report_error(kCmd, s.error(), 2);
  const std::string out = args->get("--out");
  struct stat st{};
  if (!args->has("--overwrite") && ::stat(out.c_str(), &st) == 0)
    return report_error(kCmd, error(ErrorCode::kInvalidArgument, out + ": exists (a log is never overwritten; "
                                                                       "give another file or --overwrite)"), 2);

  auto source_or = open_source(args->get("--source"));
  if (!source_or.ok()) return report_error(kCmd, source_or.error(), 1);
  FrameSource& source = **source_or;
  const SourceInfo& info = source.info();
  report_warning(kCmd, info.warning);
  if (!info.has_color) options.color = "none";

  McapFrameLog log;
  if (Status s = log.open(out, options, info.intrinsics.width, info.intrinsics.height, info.intrinsics); !s.ok())
    return report_error(kCmd, s.error(), 1);
  auto encoder = log.make_encoder();
  (void)log.log_text(0, foxglove::LogLevel::kInfo, "edgefusion log: recording " + info.uri, *encoder);

  Frame frame;
  frame.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  int64_t expected = info.frame_count;
  if (*max_frames > 0 && (expected < 0 || *max_frames < expected)) expected = *max_frames;
  Progress progress("log", expected, !args->has("--quiet"));
  const bool realtime = args->has("--realtime") && !info.live;
  // A camera: its own thread and a ring of 4 frames between it and the writer.
  std::unique_ptr<pipeline::CaptureThread> capture;
  if (info.live) {
    capture = std::make_unique<pipeline::CaptureThread>(source, 4);
    capture->start();
  }
  const auto wall0 = std::chrono::steady_clock::now();
  const double cpu0 = cpu_seconds();
  double t0 = 0;
  int64_t frames = 0;
  int exit_code = 0;
  std::string ending = "the source ended";
  StopSignalScope stop_signal;
  while (*max_frames < 0 || frames < *max_frames) {
    if (stop_signal.stop_requested()) {
      ending = stop_signal.signal_number() == SIGINT ? "SIGINT" : "SIGTERM";
      std::fprintf(stderr, "\n%s: %s received after %lld frames: closing %s\n", kCmd, ending.c_str(),
                   static_cast<long long>(frames), out.c_str());
      break;
    }
    Result<bool> got = false;
    if (capture != nullptr) {
      pipeline::CapturedFrame* slot = capture->acquire(std::chrono::milliseconds(200));
      if (slot == nullptr) continue;  // nothing yet: check the stop request again
      if (slot->end) {
        got = slot->error ? Result<bool>(*slot->error) : Result<bool>(false);
      } else {
        copy_frame(slot->frame, frame);
        got = true;
      }
      capture->release();
    } else {
      got = source.next(frame);
    }
    if (!got.ok()) {
      if (is_camera_lost(info, got.error())) {
        ending = "the camera was lost";
        std::fprintf(stderr, "\n%s: the camera was lost after %lld frames: closing %s\n", kCmd,
                     static_cast<long long>(frames), out.c_str());
      } else {
        report_error(kCmd, got.error(), 1);
        ending = "error: " + got.error().message;
        exit_code = 1;  // the frames logged so far are kept: the log is closed properly below
      }
      break;
    }
    if (!*got) break;
    if (realtime) {  // released no earlier than its recorded time after the first frame
      if (frames == 0) t0 = frame.timestamp;
      std::this_thread::sleep_until(wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                std::chrono::duration<double>(frame.timestamp - t0)));
    }
    if (Status s = log.log_frame(frame, *encoder); !s.ok()) {
      report_error(kCmd, s.error(), 1);
      exit_code = 1;
      break;
    }
    ++frames;
    progress.update(frames);
  }
  progress.finish(frames);
  uint64_t dropped = 0;
  if (capture != nullptr) {
    capture->stop();
    dropped = capture->dropped() + capture->corrupt_dropped();
  }
  (void)log.log_text(frame.timestamp, exit_code == 0 ? foxglove::LogLevel::kInfo : foxglove::LogLevel::kError,
                     "edgefusion log: stopped after " + std::to_string(frames) + " frames: " + ending, *encoder);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = cpu_seconds() - cpu0;
  if (Status s = log.close(); !s.ok()) return report_error(kCmd, s.error(), 1);
  struct stat done{};
  const double mb = ::stat(out.c_str(), &done) == 0 ? double(done.st_size) / 1e6 : 0;
  std::printf("logged %lld frames (%dx%d) to %s: %.1f MB, %.1f s, %.1f Hz, CPU %.2f ms per frame\n",
              static_cast<long long>(frames), info.intrinsics.width, info.intrinsics.height, out.c_str(), mb, wall,
              wall > 0 ? double(frames) / wall : 0.0, frames > 0 ? 1000.0 * cpu / double(frames) : 0.0);
  if (capture != nullptr)
    std::printf("camera frames dropped: %llu (the ring was full while the log was written, or the camera marked "
                "them corrupt)\n", static_cast<unsigned long long>(dropped));
  return exit_code;
}

const std::vector<OptionSpec>& log_options() { return kLogOptions; }

}  // namespace ef::app
