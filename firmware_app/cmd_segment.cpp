// `edgefusion segment`: runs the segmentation network on a source and writes class-id images in the
// layout `edgefusion convert --to tum:` uses for ground truth, so that
// `edgefusion eval labels GT/labels OUT/labels` scores the network directly.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <string>

#include "args.h"
#include "commands.h"
#include "stop_signal.h"
#include "core/classes.h"
#include "core/frame.h"
#include "core/stage_stats.h"
#include "core/stopwatch.h"
#include "io/image_codec.h"
#include "io/label_image.h"
#include "pipeline/model_paths.h"
#include "npy_writer.h"
#include "platform/cpu/cpu_features.h"
#include "core/progress.h"
#include "semantic/model_stats.h"
#include "semantic/segmenter.h"
#include "sources/open_source.h"

namespace ef::app {

using pipeline::check_model_file;
using pipeline::default_model_path;
using pipeline::models_dir;
using pipeline::models_dir_overridden;

namespace {

namespace fs = std::filesystem;

const std::vector<OptionSpec> kSegmentOptions = {
    {"--model", "MODEL", "network (.efm); default $EDGEFUSION_MODEL, else the shipped one for the source: "
                         "models/deeplabv3-mnv2-nyu13.efm for recordings and cameras, models/edgefusion-seg.efm "
                         "for the synthetic rooms"},
    {"--source", "URI", "frame source (see below)", true},
    {"--out", "DIR", "output folder, created if missing", true},
    {"--frames", "N", "read at most N frames of the source; default all"},
    {"--every", "K", "segment every K-th frame read (the first, then every K-th); default 1"},
    {"--probabilities", "", "also write probabilities/<stem>.npy (float32 H'xW'xclasses at the network's output size)"},
    {"--isa", "NAME", "highest kernel ISA: scalar, sse41, avx2, avxvnni, avx512vnni, neon, neondot; default the best "
                      "the CPU and EF_ISA allow"},
    {"--threads", "N", "threads splitting each convolution, 1..64; default 1"},
    {"--quiet", "", "no progress line"},
};

std::string segment_help() {
  return format_help(
      "edgefusion segment [--model MODEL] --source URI --out DIR [--frames N] [--every K] [--probabilities]\n"
      "                          [--isa NAME] [--threads N]",
      "Runs the segmentation network on every K-th frame of a source. Each frame is resampled to the\n"
      "network's input size exactly as 'edgefusion convert --resolution' does (colour area-averaged, depth\n"
      "block-averaged keeping the near surface), so the network sees what it was trained on. Writes into DIR:\n"
      "  labels/<stem>.png          8-bit class ids (0 unknown, 1..13 the NYUv2 classes) at the source frame's\n"
      "                             size: the network's argmax upsampled by nearest neighbour\n"
      "  labels_color/<stem>.png    the same in the paper's palette\n"
      "  probabilities/<stem>.npy   with --probabilities: float32 H'xW'xclasses at the network's output size\n"
      "<stem> is the frame's name as 'edgefusion convert --to tum:DIR' writes DIR/labels/<stem>.png, so\n"
      "'edgefusion eval labels DIR_GT/labels DIR/labels' compares them (with --every K, pass --every K there\n"
      "too). Prints frames, the forward pass's median milliseconds and the kernel ISA at the end.\n\n"
      "Sources: " + std::string(source_uri_help()),
      kSegmentOptions);
}

// The file stem of a frame: the one TumWriter uses (its name, else its timestamp with 6 decimals).
Result<std::string> frame_stem(const Frame& f) {
  char ts[64];
  std::snprintf(ts, sizeof ts, "%.6f", f.timestamp);
  const std::string stem = f.name.empty() ? std::string(ts) : f.name;
  if (stem.find('/') != std::string::npos || stem.find('\\') != std::string::npos || stem[0] == '.')
    return error(ErrorCode::kInvalidArgument, "frame " + std::to_string(f.index) + ": name '" + stem +
                                                  "' cannot be a file stem");
  return stem;
}

Status make_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return error(ErrorCode::kIoError, "cannot create folder '" + dir.string() + "': " + ec.message());
  return Status::success();
}

}  // namespace

int cmd_segment(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion segment";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", segment_help().c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kSegmentOptions, 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto max_frames = args->get_int("--frames", -1, 1, INT64_MAX);
  if (!max_frames.ok()) return report_error(kCmd, max_frames.error(), 2);
  auto every = args->get_int("--every", 1, 1, 1000000);
  if (!every.ok()) return report_error(kCmd, every.error(), 2);
  auto threads = args->get_int("--threads", 1, 1, 64);
  if (!threads.ok()) return report_error(kCmd, threads.error(), 2);
  semantic::SegmenterOptions seg_options;
  if (args->has("--isa")) {
    auto isa = semantic::parse_isa(args->get("--isa"), "--isa");
    if (!isa.ok()) return report_error(kCmd, isa.error(), 2);
    // A cap the CPU cannot reach would silently run a lower level: say so instead.
    if (!kernels::isa_available(*isa))
      return report_error(kCmd, error(ErrorCode::kInvalidArgument,
                                      "--isa " + args->get("--isa") + ": not available here (this CPU, capped by "
                                      "EF_ISA, allows: " + cpu_features().describe() + ")"), 2);
    seg_options.max_isa = *isa;
  }
  const bool want_probabilities = args->has("--probabilities");

  const bool default_model = !args->has("--model");
  const std::string model_path = default_model ? default_model_path(args->get("--source")) : args->get("--model");
  if (Status s = check_model_file(model_path, default_model); !s.ok()) return report_error(kCmd, s.error(), 1);

  // Threads first: the segmenter borrows the pool.
  ThreadPoolOptions pool_options;
  pool_options.threads = static_cast<int>(*threads);
  auto pool = ThreadPool::create(pool_options);
  if (!pool.ok()) return report_error(kCmd, pool.error(), 1);
  seg_options.pool = pool->get();
  auto seg_or = semantic::Segmenter::create(model_path, seg_options);
  if (!seg_or.ok()) return report_error(kCmd, seg_or.error(), 1);
  semantic::Segmenter& seg = **seg_or;
  const nn::ModelDesc& desc = seg.model().desc;
  // Output channel k is class id k; ids above 13 are not NYUv2 classes and eval would reject them.
  if (seg.num_classes() > kNumClassesWithUnknown)
    return report_error(kCmd, error(ErrorCode::kUnsupported,
                                    model_path + ": the network has " + std::to_string(seg.num_classes()) +
                                        " classes; segment writes class ids 0..13 and needs at most 14"), 1);
  for (int k = 0; k < seg.num_classes(); ++k)
    if (seg.class_name(k) != class_name(k)) {
      std::fprintf(stderr, "%s: note: class %d of %s is '%s', not '%s': ids are written as the network numbers them\n",
                   kCmd, k, model_path.c_str(), seg.class_name(k).c_str(),
                   std::string(class_name(k)).c_str());
      break;
    }

  auto source_or = open_source(args->get("--source"));
  if (!source_or.ok()) return report_error(kCmd, source_or.error(), 1);
  report_warning(kCmd, (*source_or)->info().warning);
  FrameSource& source = **source_or;
  const SourceInfo& info = source.info();

  const fs::path out_dir = args->get("--out");
  const fs::path labels_dir = out_dir / "labels", color_dir = out_dir / "labels_color",
                 probs_dir = out_dir / "probabilities";
  for (const fs::path& d : {labels_dir, color_dir})
    if (Status s = make_dir(d); !s.ok()) return report_error(kCmd, s.error(), 1);
  if (want_probabilities)
    if (Status s = make_dir(probs_dir); !s.ok()) return report_error(kCmd, s.error(), 1);

  // Buffers at the source's size, once; a source that changes size mid-stream reallocates them.
  Frame input;
  input.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  Image<uint8_t> labels(info.intrinsics.width, info.intrinsics.height);
  Image<Rgb8> color_scratch(info.intrinsics.width, info.intrinsics.height);
  const std::size_t probs_shape[3] = {std::size_t(seg.output_height()), std::size_t(seg.output_width()),
                                      std::size_t(seg.num_classes())};
  StageStats stats;
  const int st_forward = stats.add_stage("forward");
  const int st_segment = stats.add_stage("segment");
  const int st_write = stats.add_stage("write");
  std::set<std::string> stems;

  int64_t expected = info.frame_count;
  if (*max_frames > 0 && (expected < 0 || *max_frames < expected)) expected = *max_frames;
  std::fprintf(stderr, "%s: %s (%dx%d) -> network %s (input %dx%d, output %dx%d x %d classes), every %lld frame(s), "
               "%lld thread(s)\n", kCmd, args->get("--source").c_str(), info.intrinsics.width, info.intrinsics.height,
               desc.name.c_str(), seg.input_width(), seg.input_height(), seg.output_width(), seg.output_height(),
               seg.num_classes(), static_cast<long long>(*every), static_cast<long long>(*threads));
  Progress progress("segment", expected, !args->has("--quiet"));

  int64_t read = 0, segmented = 0;
  int exit_code = 0;
  // SIGINT / SIGTERM: finish the frame in hand, then the summary below (the images so far are whole).
  StopSignalScope stop_signal;
  bool stopped = false;
  const auto fail = [&](const Error& e) {
    report_error(kCmd, e, 1);
    exit_code = 1;  // the frames already written are kept
  };
  while (*max_frames < 0 || read < *max_frames) {
    if (stop_signal.stop_requested()) {
      stopped = true;
      std::fprintf(stderr, "\n%s: %s received after %lld frames: stopping\n", kCmd,
                   stop_signal.signal_number() == SIGINT ? "SIGINT" : "SIGTERM", static_cast<long long>(read));
      break;
    }
    auto got = source.next(input);
    if (!got.ok()) {
      fail(got.error());
      break;
    }
    if (!*got) break;
    const bool run_this = read % *every == 0;
    ++read;
    if (!run_this) {
      progress.update(read);
      continue;
    }
    labels.allocate(input.color.width(), input.color.height());  // no-op unless the size changed
    if (Status s = seg.segment(input, labels.view()); !s.ok()) {
      fail(s.error());
      break;
    }
    stats.record_ms(st_forward, seg.last_timings().forward_ms);
    stats.record_ms(st_segment, seg.last_timings().total_ms);

    const SteadyClock::time_point t_write = SteadyClock::now();
    auto stem = frame_stem(input);
    if (!stem.ok()) {
      fail(stem.error());
      break;
    }
    if (!stems.insert(*stem).second) {
      fail(error(ErrorCode::kInvalidArgument, "frame " + std::to_string(input.index) + ": name '" + *stem +
                                                  "' used twice; its files would be overwritten"));
      break;
    }
    const std::string file = *stem + ".png";
    Status s = write_png((labels_dir / file).string(), labels.cview());
    if (s.ok()) s = write_label_png_color((color_dir / file).string(), labels.cview(), color_scratch);
    if (s.ok() && want_probabilities)
      s = write_npy_f32((probs_dir / (*stem + ".npy")).string(), seg.probabilities().data, probs_shape, 3);
    if (!s.ok()) {
      fail(s.error());
      break;
    }
    stats.record_ms(st_write, ms_since(t_write));
    ++segmented;
    progress.update(read);
  }
  progress.finish(read);

  const StageSummary forward = stats.summary(st_forward), total = stats.summary(st_segment);
  const std::string isa = semantic::kernel_isa_summary(seg.executor(), desc.layers.size());
  std::printf("segmented %lld of %lld frames (source %dx%d, network input %dx%d, output %dx%d x %d classes) into %s%s\n",
              static_cast<long long>(segmented), static_cast<long long>(read), info.intrinsics.width,
              info.intrinsics.height, seg.input_width(), seg.input_height(), seg.output_width(), seg.output_height(),
              seg.num_classes(), out_dir.string().c_str(), stopped ? "; stopped by a signal" : "");
  std::printf("forward pass: median %.3f ms/frame (p95 %.3f ms); resample + forward + argmax + upsample: median "
              "%.3f ms/frame; kernel ISA %s, %lld thread(s)\n",
              forward.median_ms, forward.p95_ms, total.median_ms, isa.c_str(), static_cast<long long>(*threads));
  return exit_code;
}

const std::vector<OptionSpec>& segment_options() { return kSegmentOptions; }

}  // namespace ef::app
