// Times slam::Tracker::track() and measures its frame-to-frame accuracy on real frames.
//   bench_slam_track [--frames N] [--start S] [--gap G] [--reps R] [--size 320x240]
//                    [--iters 10,5,4] [--stop S] [--so3 0|1] [--so3-iters N] [--per-pair] [--kernels]
// Reads frames S .. S+N+G-1 of 7-Scenes redkitchen from the shared data, resamples them to the
// working size and preprocesses them (3 levels), then tracks frame f+G against frame f for N pairs
// (reference = f, current = f+G, identity guess: frame to frame without a motion model), each pair R
// times (default 3). Prints the median / mean / p90 milliseconds per track() call over all calls (wall
// clock; and, steadier on a shared machine, the median thread CPU time and the median over pairs of
// each pair's fastest call) and the error of the estimated relative pose against the dataset's
// reference poses (translation mm, rotation deg: median, mean, p90, max), lost frames and
// Gauss-Newton steps. One thread.
// --iters sets TrackerOptions::iterations fine to coarse; --stop sets both stop thresholds
// (stop_translation_m and stop_rotation_rad); --so3 and --so3-iters set TrackerOptions::so3_prealign
// and so3_iterations.
// --kernels times the track_rows variants instead (see bench_kernels below).
// Without the 7-Scenes data it exits with status 0 after saying so (nothing to measure on).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <utility>
#include <vector>

#include "io/frame_resample.h"
#include "kernels/normal_equations.h"
#include "kernels/reduce_normal_equations_variants.h"
#include "kernels/track_rows_variants.h"
#include "slam/preprocess.h"
#include "slam/tracker.h"
#include "sources/open_source.h"

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t i = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}
// CPU time of this thread, milliseconds: less disturbed than wall time when the machine is shared.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}
double maximum(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

// --kernels: every track_rows variant this CPU runs, on level 0 of one real pair at the pose the
// tracker found (gates as TrackerOptions' defaults), rows of the whole level written to full-size SoA
// buffers; then the dispatched reduce_normal_equations of both terms. Prints the median and the fastest
// of `reps` passes, milliseconds per pass of the level.
int bench_kernels(const ef::slam::PyramidView& ref, const ef::slam::PyramidView& cur, const ef::SE3& T,
                  const ef::slam::TrackerOptions& o, int reps) {
  const ef::slam::TrackerLevelView& r = ref.level[0];
  const ef::slam::TrackerLevelView& c = cur.level[0];
  ef::kernels::TrackRowsParams P;
  const Eigen::Matrix3f R = T.rotation_matrix().cast<float>();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) P.R[3 * i + j] = R(i, j);
    P.t[i] = static_cast<float>(T.translation()(i));
  }
  P.fx = r.intrinsics.fx;
  P.fy = r.intrinsics.fy;
  P.cx = r.intrinsics.cx;
  P.cy = r.intrinsics.cy;
  P.width = r.intrinsics.width;
  P.height = r.intrinsics.height;
  P.ref_vertex = reinterpret_cast<const float*>(r.vertex.data);
  P.ref_normal = reinterpret_cast<const float*>(r.normal.data);
  P.ref_intensity = r.intensity.data;
  P.ref_grad_x = r.grad_x.data;
  P.ref_grad_y = r.grad_y.data;
  P.vertex_stride = static_cast<std::ptrdiff_t>(r.vertex.stride_bytes / 4);
  P.normal_stride = static_cast<std::ptrdiff_t>(r.normal.stride_bytes / 4);
  P.intensity_stride = static_cast<std::ptrdiff_t>(r.intensity.stride_bytes / 4);
  P.grad_x_stride = static_cast<std::ptrdiff_t>(r.grad_x.stride_bytes / 4);
  P.grad_y_stride = static_cast<std::ptrdiff_t>(r.grad_y.stride_bytes / 4);
  P.icp_max_d2 = o.icp_max_distance_m * o.icp_max_distance_m;
  const float s = static_cast<float>(std::sin(o.icp_max_normal_angle_deg * M_PI / 180.0));
  P.icp_sin2_max = s * s;
  P.rgb_huber_grey = static_cast<float>(o.rgb_huber_k * o.rgb_sigma_grey);
  P.rgb_max_depth_diff = o.rgb_max_depth_diff_m;
  P.rgb_max_depth = o.rgb_max_depth_m;
  const int w = c.intrinsics.width, h = c.intrinsics.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<float> icp(8 * n), rgb(8 * n);
  ef::kernels::TrackRowsCounts counts;
  const auto pass = [&](ef::kernels::TrackRowsFn fn) {
    counts = {};
    for (int y = 0; y < h; ++y)
      fn(P, reinterpret_cast<const float*>(c.vertex.row(y)), reinterpret_cast<const float*>(c.normal.row(y)),
         c.intensity.row(y), static_cast<std::size_t>(w), icp.data() + static_cast<std::size_t>(y) * w,
         rgb.data() + static_cast<std::size_t>(y) * w, n, &counts);
  };
  const auto time = [&](const auto& f) {
    std::vector<double> t;
    for (int k = 0; k < reps; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      f();
      t.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    return std::pair<double, double>(percentile(t, 0.5), percentile(t, 0.0));
  };
  std::printf("track_rows on level 0 (%dx%d = %zu px), 7-Scenes pair, %d passes: ms per pass (median / fastest)\n", w,
              h, n, reps);
  for (const auto& v : ef::kernels::kTrackRowsVariants) {
    if (!ef::kernels::isa_available(v.isa, ef::detected_cpu_features())) continue;
    pass(v.fn);  // warm-up
    const auto [med, best] = time([&] { pass(v.fn); });
    std::printf("  %-24s %7.3f / %7.3f ms  (%.0f Mpx/s; %lld valid, %lld ICP rows, %lld RGB rows)\n", v.name, med, best,
                static_cast<double>(n) / best * 1e-3, static_cast<long long>(counts.valid),
                static_cast<long long>(counts.icp), static_cast<long long>(counts.rgb));
  }
  ef::kernels::NormalEquations ne;
  const auto [med, best] = time([&] {
    ef::kernels::reduce_normal_equations(icp.data(), n, n, &ne);
    ef::kernels::reduce_normal_equations(rgb.data(), n, n, &ne);
  });
  std::printf("  %-24s %7.3f / %7.3f ms  (both terms, dispatched: %s)\n", "reduce_normal_equations", med, best,
              ef::kernels::reduce_normal_equations_selected());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 200, start = 0, gap = 1, reps = 3, width = 320, height = 240;
  int so3 = -1;
  bool per_pair = false, kernels = false;
  ef::slam::TrackerOptions options;
  for (int i = 1; i < argc; ++i) {
    const bool has = i + 1 < argc;
    if (!std::strcmp(argv[i], "--per-pair")) {
      per_pair = true;
    } else if (!std::strcmp(argv[i], "--kernels")) {
      kernels = true;
    } else if (has && !std::strcmp(argv[i], "--frames")) {
      frames = std::max(1, std::atoi(argv[++i]));
    } else if (has && !std::strcmp(argv[i], "--start")) {
      start = std::max(0, std::atoi(argv[++i]));
    } else if (has && !std::strcmp(argv[i], "--gap")) {
      gap = std::max(1, std::atoi(argv[++i]));
    } else if (has && !std::strcmp(argv[i], "--reps")) {
      reps = std::max(1, std::atoi(argv[++i]));
    } else if (has && !std::strcmp(argv[i], "--stop")) {
      options.stop_translation_m = options.stop_rotation_rad = std::atof(argv[++i]);
    } else if (has && !std::strcmp(argv[i], "--so3-iters")) {
      options.so3_iterations = std::atoi(argv[++i]);
    } else if (has && !std::strcmp(argv[i], "--so3")) {
      so3 = std::atoi(argv[++i]) != 0;
    } else if (has && !std::strcmp(argv[i], "--iters")) {
      int it[ef::slam::kTrackerMaxLevels] = {};
      const int got = std::sscanf(argv[++i], "%d,%d,%d,%d,%d,%d", &it[0], &it[1], &it[2], &it[3], &it[4], &it[5]);
      for (int l = 0; l < got; ++l) options.iterations[l] = it[l];
    } else if (has && !std::strcmp(argv[i], "--size")) {
      if (std::sscanf(argv[++i], "%dx%d", &width, &height) != 2) {
        std::fprintf(stderr, "--size wants WxH\n");
        return 2;
      }
    } else {
      std::fprintf(stderr, "unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  if (so3 >= 0) options.so3_prealign = so3 != 0;

  const char* env = std::getenv("EF_SHARED_DATA");
  const std::filesystem::path data =
      std::filesystem::path(env && *env ? env : EF_SHARED_DATA_DIR) / "7scenes-redkitchen";
  if (!std::filesystem::is_directory(data)) {
    std::printf("bench_slam_track: no 7-Scenes data at %s; nothing measured\n", data.string().c_str());
    return 0;
  }
  auto src = ef::open_source("7scenes:" + data.string());
  if (!src.ok()) {
    std::fprintf(stderr, "%s\n", ef::to_string(src.error()).c_str());
    return 1;
  }
  const ef::Intrinsics K = (*src)->info().intrinsics.scaled_to(width, height);
  auto tracker_made = ef::slam::Tracker::create(K, 3, options);
  if (!tracker_made.ok()) {
    std::fprintf(stderr, "%s\n", ef::to_string(tracker_made.error()).c_str());
    return 1;
  }
  ef::slam::Tracker& tracker = *tracker_made;

  // A ring of gap + 1 preprocessed frames: slot f % (gap + 1) holds frame f.
  std::vector<std::unique_ptr<ef::slam::Preprocessor>> ring;
  std::vector<ef::SE3> pose(static_cast<std::size_t>(gap + 1));
  for (int i = 0; i <= gap; ++i) {
    auto p = ef::slam::Preprocessor::create(K);
    if (!p.ok()) return 1;
    ring.push_back(std::make_unique<ef::slam::Preprocessor>(std::move(p).value()));
  }
  ef::Frame full, work;
  work.allocate(width, height, false);

  std::vector<double> ms, cpu_ms, best_ms, err_t_mm, err_r_deg, steps;
  double level_steps[3] = {};
  int lost = 0, pairs = 0, so3_applied = 0;
  double so3_deg = 0, so3_steps = 0;
  ef::slam::TrackResult r;
  for (int f = 0; f < start + frames + gap; ++f) {
    auto got = (*src)->next(full);
    if (!got.ok()) {
      std::fprintf(stderr, "%s\n", ef::to_string(got.error()).c_str());
      return 1;
    }
    if (!*got) break;
    if (f < start) continue;
    ef::resample_frame(full, work);
    const std::size_t slot = static_cast<std::size_t>(f % (gap + 1));
    if (!ring[slot]->process(work).ok()) return 1;
    pose[slot] = work.T_wc;
    if (f - start < gap) continue;
    const std::size_t ref = static_cast<std::size_t>((f - gap) % (gap + 1));
    const ef::slam::PyramidView vr = ef::slam::pyramid_view(*ring[ref]), vc = ef::slam::pyramid_view(*ring[slot]);
    if (kernels) {
      if (!tracker.track(vr, vc, ef::SE3(), &r).ok()) return 1;
      return bench_kernels(vr, vc, r.T_ref_cur, options, std::max(reps, 20));
    }
    double best = 1e30;
    for (int k = 0; k < reps; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = thread_cpu_ms();
      if (!tracker.track(vr, vc, ef::SE3(), &r).ok()) return 1;
      cpu_ms.push_back(thread_cpu_ms() - c0);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      best = std::min(best, ms.back());
    }
    best_ms.push_back(best);
    const ef::SE3 truth = pose[ref].inverse() * pose[slot];
    const ef::SE3 d = r.T_ref_cur.inverse() * truth;
    err_t_mm.push_back(d.translation().norm() * 1e3);
    err_r_deg.push_back(d.angle() * 180.0 / M_PI);
    steps.push_back(r.iterations);
    for (int l = 0; l < 3; ++l) level_steps[l] += r.level_iterations[l];
    lost += r.lost;
    so3_applied += r.so3_applied;
    so3_deg += r.so3_rotation_deg;
    so3_steps += r.so3_iterations;
    ++pairs;
    if (per_pair)
      std::printf("pair %4d -> %4d  motion %6.1f mm %5.2f deg  error %6.2f mm %6.3f deg  iters %2d  so3 %.2f deg%s\n",
                  f - gap, f, truth.translation().norm() * 1e3, truth.angle() * 180.0 / M_PI, err_t_mm.back(),
                  err_r_deg.back(), r.iterations, r.so3_rotation_deg, r.lost ? " LOST" : "");
  }
  std::printf(
      "Tracker at %dx%d, 3 levels, iterations %d/%d/%d (fine to coarse), stop %g m / %g rad, "
      "so3_prealign %d (%d steps at most); 7-Scenes redkitchen frames %d.., %d pairs f -> f+%d, identity guess, %d "
      "reps\n",
      width, height, options.iterations[0], options.iterations[1], options.iterations[2], options.stop_translation_m,
      options.stop_rotation_rad, tracker.options().so3_prealign ? 1 : 0, tracker.options().so3_iterations, start, pairs,
      gap, reps);
  std::printf(
      "  ms per track():  median %.3f  mean %.3f  p90 %.3f  (thread CPU time: median %.3f; median over "
      "pairs of the fastest of the %d calls: %.3f)\n",
      percentile(ms, 0.5), mean(ms), percentile(ms, 0.9), percentile(cpu_ms, 0.5), reps, percentile(best_ms, 0.5));
  std::printf("  translation error mm:  median %.3f  mean %.3f  p90 %.3f  max %.3f\n", percentile(err_t_mm, 0.5),
              mean(err_t_mm), percentile(err_t_mm, 0.9), maximum(err_t_mm));
  std::printf("  rotation error deg:    median %.4f  mean %.4f  p90 %.4f  max %.4f\n", percentile(err_r_deg, 0.5),
              mean(err_r_deg), percentile(err_r_deg, 0.9), maximum(err_r_deg));
  std::printf("  lost %d of %d; Gauss-Newton steps per track(): mean %.2f (levels 0/1/2: %.2f %.2f %.2f)\n", lost,
              pairs, mean(steps), level_steps[0] / pairs, level_steps[1] / pairs, level_steps[2] / pairs);
  if (tracker.options().so3_prealign)
    std::printf("  SO(3) pre-alignment: applied on %d of %d pairs, mean %.3f deg where applied; %.2f steps per call\n",
                so3_applied, pairs, so3_applied ? so3_deg / so3_applied : 0.0, so3_steps / pairs);
  return 0;
}
