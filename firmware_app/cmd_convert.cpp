// `edgefusion convert`: any source to an ElasticFusion .klg log, a TUM RGB-D folder or an MCAP field
// log. This is how synthetic sequences are exported for training and evaluation.
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>

#include "args.h"
#include "commands.h"
#include "core/frame.h"
#include "io/frame_resample.h"
#include "io/klg_format.h"
#include "io/mcap_log.h"
#include "io/tum_writer.h"
#include "core/progress.h"
#include "sources/open_source.h"
#include "stop_signal.h"

namespace ef::app {

namespace {

const std::vector<OptionSpec> kConvertOptions = {
    {"--source", "URI", "frame source (see edgefusion run --help)", true},
    {"--to", "TARGET", "klg:FILE (ElasticFusion log), tum:DIR (TUM RGB-D folder) or mcap:FILE (field log)", true},
    {"--frames", "N", "convert at most N frames; default all"},
    {"--resolution", "WxH", "resample to this size first; default the source's own"},
    {"--jpeg-quality", "Q", "klg, mcap: JPEG quality 1..100 for colour, 0 = raw RGB; default 90"},
    {"--raw-depth", "", "klg, mcap: store depth uncompressed instead of zlib / PNG"},
    {"--quiet", "", "no progress line"},
};

// One target writer behind a common face.
struct Target {
  std::string kind;  // klg, tum, mcap
  KlgWriter klg;
  TumWriter tum;
  McapFrameLog mcap;
  std::unique_ptr<McapFrameLog::Encoder> encoder;
  Status write(const Frame& f) {
    if (kind == "mcap") return mcap.log_frame(f, *encoder);
    return kind == "klg" ? klg.write(f) : tum.write(f);
  }
  Status close() {
    if (kind == "mcap") return mcap.close();
    return kind == "klg" ? klg.close() : tum.close();
  }
};

}  // namespace

int cmd_convert(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion convert";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", format_help("edgefusion convert --source URI --to klg:FILE|tum:DIR|mcap:FILE [--frames N]",
                                  "Writes a source as an ElasticFusion .klg log (int32 frame count; per frame\n"
                                  "int64 timestamp in microseconds, zlib depth in millimetres, JPEG colour; beside it\n"
                                  "FILE.intrinsics.txt with the size and camera, which klg:FILE reads back) or as a\n"
                                  "TUM RGB-D folder (rgb/, depth/ at 5000 per metre, rgb.txt, depth.txt,\n"
                                  "groundtruth.txt when poses exist, labels/ when the source has labels,\n"
                                  "intrinsics.txt), or as an MCAP field log (PNG depth, JPEG colour, calibration,\n"
                                  "reference poses; docs/field_log.md lists its topics).\n"
                                  "SIGINT / SIGTERM stop after the frame in hand and finish the target (exit 0).\n"
                                  "A target cut harder (kill -9, power) still reads back: each frame's data is\n"
                                  "written whole before the .klg frame count or the TUM lists name it.\n\n"
                                  "Sources: " + std::string(source_uri_help()),
                                  kConvertOptions).c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kConvertOptions, 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto max_frames = args->get_int("--frames", -1, 1, INT64_MAX);
  if (!max_frames.ok()) return report_error(kCmd, max_frames.error(), 2);
  auto quality = args->get_int("--jpeg-quality", 90, 0, 100);
  if (!quality.ok()) return report_error(kCmd, quality.error(), 2);

  const std::string to = args->get("--to");
  const auto colon = to.find(':');
  const std::string kind = colon == std::string::npos ? "" : to.substr(0, colon);
  const std::string target_path = colon == std::string::npos ? "" : to.substr(colon + 1);
  if ((kind != "klg" && kind != "tum" && kind != "mcap") || target_path.empty())
    return report_error(kCmd, error(ErrorCode::kInvalidArgument,
                                    "--to: '" + to + "' is not klg:FILE, tum:DIR or mcap:FILE"), 2);

  auto source_or = open_source(args->get("--source"));
  if (!source_or.ok()) return report_error(kCmd, source_or.error(), 1);
  report_warning(kCmd, (*source_or)->info().warning);
  FrameSource& source = **source_or;
  const SourceInfo& info = source.info();

  int width = info.intrinsics.width, height = info.intrinsics.height;
  if (args->has("--resolution")) {
    auto r = parse_resolution(args->get("--resolution"), "--resolution");
    if (!r.ok()) return report_error(kCmd, r.error(), 2);
    width = r->first;
    height = r->second;
  }
  const bool resample = width != info.intrinsics.width || height != info.intrinsics.height;

  Target target;
  target.kind = kind;
  Status opened;
  if (kind == "klg") {
    opened = target.klg.open(target_path, width, height,
                             KlgWriteOptions{!args->has("--raw-depth"), static_cast<int>(*quality)});
    // The size and the camera beside the recording (a .klg holds neither): `klg:FILE` reads them
    // back, so converting to .klg and back keeps the source's intrinsics (issue 33).
    if (opened.ok()) opened = write_klg_side_file(target_path, info.intrinsics.scaled_to(width, height));
  } else if (kind == "tum") {
    opened = target.tum.open(target_path, info.intrinsics.scaled_to(width, height));
  } else {
    McapLogOptions log;
    log.depth = args->has("--raw-depth") ? "raw" : "png";
    log.color = !info.has_color ? "none" : *quality == 0 ? "raw" : "jpeg";
    log.jpeg_quality = *quality == 0 ? 90 : *quality;
    opened = target.mcap.open(target_path, log, width, height, info.intrinsics.scaled_to(width, height));
    if (opened.ok()) target.encoder = target.mcap.make_encoder();
  }
  if (!opened.ok()) return report_error(kCmd, opened.error(), 1);

  Frame input, resized;
  input.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  if (resample) resized.allocate(width, height, info.has_labels);
  int64_t expected = info.frame_count;
  if (*max_frames > 0 && (expected < 0 || *max_frames < expected)) expected = *max_frames;
  Progress progress("convert", expected, !args->has("--quiet"));

  int64_t frames = 0;
  int exit_code = 0;
  // SIGINT / SIGTERM: stop after the frame in hand and finish the target (as `run` does), exit 0.
  StopSignalScope stop_signal;
  while (*max_frames < 0 || frames < *max_frames) {
    if (stop_signal.stop_requested()) {
      std::fprintf(stderr, "\n%s: %s received after %lld frames: stopping, finishing %s\n", kCmd,
                   stop_signal.signal_number() == SIGINT ? "SIGINT" : "SIGTERM", static_cast<long long>(frames),
                   to.c_str());
      break;
    }
    auto got = source.next(input);
    if (!got.ok()) {
      report_error(kCmd, got.error(), 1);
      exit_code = 1;  // the frames already written are kept: the target is closed properly below
      break;
    }
    if (!*got) break;
    const Frame* out = &input;
    if (resample) {
      resample_frame(input, resized);
      out = &resized;
    }
    if (Status s = target.write(*out); !s.ok()) {
      report_error(kCmd, s.error(), 1);
      exit_code = 1;
      break;
    }
    ++frames;
    progress.update(frames);
  }
  progress.finish(frames);
  if (Status s = target.close(); !s.ok()) return report_error(kCmd, s.error(), 1);
  std::printf("converted %lld frames (%dx%d) to %s\n", static_cast<long long>(frames), width, height, to.c_str());
  return exit_code;
}

const std::vector<OptionSpec>& convert_options() { return kConvertOptions; }

}  // namespace ef::app
