// Times SurfelSlam per stage on a whole sequence, replayed exactly as `edgefusion run` replays it:
// open_source(URI), each frame resampled to the working resolution (resample_frame), then
// SurfelSlam::process with the default options (those of `edgefusion run` without a config file).
//   bench_slam_stages [--source URI] [--frames N] [--resolution WxH] [--warmup N] [--associate tracked|previous]
//                     [--window N] [--fusion-stride 1|2]
// Defaults: the 7-Scenes redkitchen sequence of the shared data when present, else
// synthetic:?frames=1000; every frame; 320x240; 10 warm-up frames; fusion associating through an
// index map at the tracked pose (SurfelSlamOptions::associate_at_tracked_pose; previous = false).
// Prints the CPU, the ISA paths in use, then per stage (preprocess, track, fuse, predict, their sum,
// process() as a whole) the median and p95 milliseconds over the frames after the warm-up (wall
// clock, SlamFrameResult::timings; track over frames after the first, fuse over fused frames), the
// thread CPU time of process(), the surfels at the end, lost frames and, when the source has
// reference poses, the ATE RMSE (TUM conventions, eval/trajectory_eval.h) over every frame.
// --fusion-stride 1 fuses every pixel, 2 (the default) every other pixel of every other row
// (FusionOptions::pixel_stride).
// --window N also prints, for every N frames, the medians of the four stages and their sum, the
// surfels at the window's end and the share of pool blocks predict visited (how the cost grows with
// the map: bench/slam_growth.sh). One thread: SurfelSlam is single threaded. Exit 2: bad options or a source that cannot be opened.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <time.h>

#include "core/frame.h"
#include "eval/trajectory_eval.h"
#include "io/frame_resample.h"
#include "kernels/bilateral_row_variants.h"
#include "kernels/depth_u16_to_metres_variants.h"
#include "kernels/fusion_gates_variants.h"
#include "kernels/reduce_normal_equations_variants.h"
#include "kernels/splat_disc_variants.h"
#include "kernels/track_rows_variants.h"
#include "platform/cpu/cpu_features.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"

namespace {

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

// Nearest-rank percentile (0 < q <= 1) of the samples; 0 when there are none.
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size(), std::max<std::size_t>(rank, 1)) - 1];
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// "model name" (x86) or the implementer/part lines (AArch64) of /proc/cpuinfo.
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, implementer, part;
  const auto value = [](const std::string& l) {
    const auto colon = l.find(':');
    std::string v = colon == std::string::npos ? std::string() : l.substr(colon + 1);
    v.erase(0, v.find_first_not_of(" \t"));
    return v;
  };
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0 || line.rfind("Model", 0) == 0) return value(line);
    if (line.rfind("CPU implementer", 0) == 0 && implementer.empty()) implementer = value(line);
    if (line.rfind("CPU part", 0) == 0 && part.empty()) part = value(line);
  }
  if (!part.empty()) return "implementer " + implementer + ", part " + part;
  return "unknown";
}

std::string default_source() {
  std::error_code ec;
  if (std::filesystem::is_directory("../shared/data/7scenes-redkitchen", ec))
    return "7scenes:../shared/data/7scenes-redkitchen";
  const std::filesystem::path shared = std::filesystem::path(EF_SHARED_DATA_DIR) / "7scenes-redkitchen";
  if (std::filesystem::is_directory(shared, ec)) return "7scenes:" + shared.string();
  return "synthetic:?frames=1000";
}

int usage(const char* why) {
  if (why) std::fprintf(stderr, "bench_slam_stages: %s\n", why);
  std::fprintf(stderr,
               "usage: bench_slam_stages [--source URI] [--frames N] [--resolution WxH] [--warmup N]\n"
               "                         [--associate tracked|previous] [--window N] [--fusion-stride 1|2]\n"
               "  --source URI       default %s\n"
               "  --frames N         frames to process, default every frame of the source\n"
               "  --resolution WxH   working resolution, default 320x240\n"
               "  --warmup N         first frames left out of the stage statistics, default 10\n"
               "  --associate WHERE  fusion's index map: at the tracked pose (default) or the previous one\n"
               "  --window N         also print the stage medians of every N frames (default 0: none)\n"
               "  --fusion-stride S  fuse every pixel (1) or every other of every other row (2, default)\n",
               default_source().c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string uri;
  int64_t max_frames = -1;
  int width = 320, height = 240, warmup = 10;
  int64_t window = 0;
  ef::slam::SurfelSlamOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string opt = argv[i];
    if (opt == "--help" || opt == "-h") {
      usage(nullptr);
      return 0;
    }
    if (i + 1 >= argc) return usage(("option " + opt + " wants a value").c_str());
    const char* v = argv[++i];
    char* end = nullptr;
    if (opt == "--source") {
      uri = v;
    } else if (opt == "--frames") {
      max_frames = std::strtoll(v, &end, 10);
      if (*end || max_frames < 1) return usage("--frames wants a positive integer");
    } else if (opt == "--warmup") {
      const long w = std::strtol(v, &end, 10);
      if (*end || w < 0) return usage("--warmup wants an integer >= 0");
      warmup = static_cast<int>(w);
    } else if (opt == "--window") {
      window = std::strtoll(v, &end, 10);
      if (*end || window < 1) return usage("--window wants a positive integer");
    } else if (opt == "--fusion-stride") {
      if (std::strcmp(v, "1") != 0 && std::strcmp(v, "2") != 0) return usage("--fusion-stride wants 1 or 2");
      options.fusion.pixel_stride = v[0] - '0';
    } else if (opt == "--associate") {
      if (std::strcmp(v, "tracked") != 0 && std::strcmp(v, "previous") != 0)
        return usage("--associate wants tracked or previous");
      options.associate_at_tracked_pose = std::strcmp(v, "tracked") == 0;
    } else if (opt == "--resolution") {
      char x = 0, extra = 0;
      if (std::sscanf(v, "%d%c%d%c", &width, &x, &height, &extra) != 3 || x != 'x' || width < 16 || height < 16)
        return usage("--resolution wants WxH, e.g. 320x240");
    } else {
      return usage(("unknown option " + opt).c_str());
    }
  }
  if (uri.empty()) uri = default_source();

  auto source_or = ef::open_source(uri);
  if (!source_or.ok()) {
    std::fprintf(stderr, "bench_slam_stages: cannot open source '%s': %s\n", uri.c_str(),
                 ef::to_string(source_or.error()).c_str());
    return 2;
  }
  ef::FrameSource& source = **source_or;
  const ef::SourceInfo& info = source.info();

  ef::Frame input, working;
  input.allocate(info.intrinsics.width, info.intrinsics.height, info.has_labels);
  working.allocate(width, height, info.has_labels);
  const ef::Intrinsics working_k = info.intrinsics.scaled_to(width, height);
  auto slam_or = ef::slam::SurfelSlam::create(working_k, options);
  if (!slam_or.ok()) {
    std::fprintf(stderr, "bench_slam_stages: %s\n", ef::to_string(slam_or.error()).c_str());
    return 2;
  }
  ef::slam::SurfelSlam& slam = *slam_or;

  std::printf("bench_slam_stages: one thread (SurfelSlam is single threaded)\n");
  std::printf("CPU: %s\n", cpu_model().c_str());
  std::printf("ISA: %s (detected: %s); kernels: %s, %s, %s, %s, %s, %s\n", ef::cpu_features().describe().c_str(),
              ef::detected_cpu_features().describe().c_str(), ef::kernels::track_rows_selected(),
              ef::kernels::reduce_normal_equations_selected(), ef::kernels::splat_disc_selected(),
              ef::kernels::depth_u16_to_metres_selected(), ef::kernels::fusion_gates_selected(),
              ef::kernels::bilateral_row_selected());
  std::printf("source: %s (%dx%d, %s frames), working resolution %dx%d (fx %.1f), warm-up %d frames, fusion "
              "associating at the %s pose\n",
              uri.c_str(), info.intrinsics.width, info.intrinsics.height,
              info.frame_count >= 0 ? std::to_string(info.frame_count).c_str() : "unknown", width, height,
              working_k.fx, warmup, options.associate_at_tracked_pose ? "tracked" : "previous");
  std::fflush(stdout);

  std::vector<double> pre_ms, track_ms, fuse_ms, predict_ms, sum_ms, process_ms, cpu_ms, input_ms;
  // Parts of fuse (fused frames) and predict, from FusionStats and PredictionTimings.
  std::vector<double> index_ms, associate_ms, clean_ms, create_ms, reorder_ms, clear_ms, render_ms, resolve_ms, pyramid_ms;
  int64_t reorders = 0;
  std::vector<double> visited_share;  // predict's pool blocks visited / blocks (slam/surfel_pool.h: block bounds)
  // The current --window's samples: preprocess, track, fuse, predict, their sum, visited share.
  std::vector<double> win[6];
  if (window > 0)
    std::printf("  %-13s %9s %8s %8s %8s %8s %8s %8s  (medians, ms; blocks: predict's share visited)\n", "frames",
                "surfels", "prepro", "track", "fuse", "predict", "sum", "blocks");
  std::vector<ef::TimedPose> estimate, reference;
  ef::slam::SlamFrameResult r;
  int64_t frames = 0, lost_measured = 0;
  const auto start = std::chrono::steady_clock::now();
  while (max_frames < 0 || frames < max_frames) {
    const auto t0 = std::chrono::steady_clock::now();
    auto got = source.next(input);
    if (!got.ok()) {
      std::fprintf(stderr, "bench_slam_stages: %s\n", ef::to_string(got.error()).c_str());
      return 1;
    }
    if (!*got) break;
    ef::resample_frame(input, working);
    const double read_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const double c0 = thread_cpu_ms();
    if (ef::Status s = slam.process(working, &r); !s.ok()) {
      std::fprintf(stderr, "bench_slam_stages: frame %lld: %s\n", static_cast<long long>(frames),
                   ef::to_string(s.error()).c_str());
      return 1;
    }
    const double c = thread_cpu_ms() - c0;
    estimate.push_back({working.timestamp, r.T_world_cam});
    if (working.has_pose) reference.push_back({working.timestamp, working.T_wc});
    if (frames >= warmup) {
      const ef::slam::SlamTimings& t = r.timings;
      pre_ms.push_back(t.preprocess_ms);
      if (frames > 0) track_ms.push_back(t.track_ms);  // frame 0 has nothing to track
      if (r.fused) {
        fuse_ms.push_back(t.fuse_ms);
        index_ms.push_back(t.index_ms);
        associate_ms.push_back(r.fusion.associate_ms);
        clean_ms.push_back(r.fusion.clean_ms);
        create_ms.push_back(r.fusion.create_ms);
        if (t.reorder_ms > 0) {
          reorder_ms.push_back(t.reorder_ms);
          ++reorders;
        }
        const ef::slam::PredictionTimings& p = slam.predictor().timings();
        clear_ms.push_back(p.clear_ms);
        render_ms.push_back(p.render_ms);
        resolve_ms.push_back(p.resolve_ms);
        pyramid_ms.push_back(p.pyramid_ms);
        const ef::slam::PredictionCounters& pc = slam.predictor().counters();
        if (pc.blocks > 0) visited_share.push_back(static_cast<double>(pc.blocks_visited) / static_cast<double>(pc.blocks));
      }
      predict_ms.push_back(t.predict_ms);
      sum_ms.push_back(t.preprocess_ms + t.track_ms + t.fuse_ms + t.predict_ms);
      process_ms.push_back(t.total_ms);
      cpu_ms.push_back(c);
      input_ms.push_back(read_ms);
      lost_measured += r.lost ? 1 : 0;
    }
    if (window > 0) {
      const ef::slam::SlamTimings& t = r.timings;
      const ef::slam::PredictionCounters& pc = slam.predictor().counters();
      const double sample[6] = {t.preprocess_ms, t.track_ms, t.fuse_ms, t.predict_ms,
                                t.preprocess_ms + t.track_ms + t.fuse_ms + t.predict_ms,
                                pc.blocks > 0 ? static_cast<double>(pc.blocks_visited) / static_cast<double>(pc.blocks) : 0};
      if (r.fused)
        for (int k = 0; k < 6; ++k) win[k].push_back(sample[k]);
      if ((frames + 1) % window == 0) {
        char span[48];  // two 64-bit frame numbers and a dash
        std::snprintf(span, sizeof(span), "%lld-%lld", static_cast<long long>(frames + 1 - window),
                      static_cast<long long>(frames));
        std::printf("  %-13s %9lld %8.2f %8.2f %8.2f %8.2f %8.2f %7.0f%%\n", span,
                    static_cast<long long>(slam.pool().size()), median(win[0]), median(win[1]), median(win[2]),
                    median(win[3]), median(win[4]), 100 * median(win[5]));
        std::fflush(stdout);
        for (auto& w : win) w.clear();
      }
    }
    ++frames;
    if (frames % 100 == 0)
      std::fprintf(stderr, "  %lld frames, %lld surfels, %lld lost\n", static_cast<long long>(frames),
                   static_cast<long long>(slam.pool().size()), static_cast<long long>(slam.lost_frames()));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::printf("%lld frames in %.1f s (%.1f fps, source decode and resample included); stages over %zu frames after "
              "the warm-up\n",
              static_cast<long long>(frames), seconds, seconds > 0 ? static_cast<double>(frames) / seconds : 0.0,
              process_ms.size());
  std::printf("  %-44s %9s %9s %7s\n", "stage (wall clock, ms per frame)", "median", "p95", "frames");
  const auto row = [](const char* name, const std::vector<double>& v) {
    std::printf("  %-44s %9.2f %9.2f %7zu\n", name, median(v), percentile(v, 0.95), v.size());
  };
  row("preprocess", pre_ms);
  row("track", track_ms);
  row("fuse (fused frames)", fuse_ms);
  row("  index map at the tracked pose", index_ms);
  row("  associate", associate_ms);
  row("  clean", clean_ms);
  row("  create", create_ms);
  row("  spatial reorder (frames it ran)", reorder_ms);
  row("predict", predict_ms);
  row("  clear", clear_ms);
  row("  render (transform, index map, discs)", render_ms);
  row("  resolve", resolve_ms);
  row("  pyramid", pyramid_ms);
  row("sum of the four (per frame)", sum_ms);
  row("process() total", process_ms);
  row("process() thread CPU time", cpu_ms);
  row("source next() + resample (not in the sum)", input_ms);
  std::printf("predict visits %.0f%% of the pool's blocks (median; p95 %.0f%%); bounds recomputed %llu times\n",
              100 * median(visited_share), 100 * percentile(visited_share, 0.95),
              static_cast<unsigned long long>(slam.pool().bounds_refreshes()));
  const ef::slam::SurfelPoolCounters& pc = slam.pool().counters();
  std::printf("surfels at the end: %lld (capacity %lld; created %llu, removed %llu, evicted %llu, refused %llu)\n",
              static_cast<long long>(slam.pool().size()), static_cast<long long>(slam.pool().capacity()),
              static_cast<unsigned long long>(pc.created), static_cast<unsigned long long>(pc.removed),
              static_cast<unsigned long long>(pc.evicted), static_cast<unsigned long long>(pc.refused));
  std::printf("lost frames: %lld of %lld (%lld after the warm-up)\n", static_cast<long long>(slam.lost_frames()),
              static_cast<long long>(frames), static_cast<long long>(lost_measured));
  if (reference.size() >= 3) {
    auto ate = ef::evaluate_ate(ef::Trajectory{"reference poses of " + uri, reference},
                                ef::Trajectory{"estimate", estimate});
    if (ate.ok())
      std::printf("ATE RMSE: %.4f m (mean %.4f, median %.4f, max %.4f; %d poses)\n", ate->rmse_m, ate->mean_m,
                  ate->median_m, ate->max_m, ate->pairs);
    else
      std::printf("ATE: %s\n", ef::to_string(ate.error()).c_str());
  } else {
    std::printf("ATE: the source has no reference poses\n");
  }
  return 0;
}
