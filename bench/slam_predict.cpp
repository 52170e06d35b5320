// Times slam::ModelPredictor::predict() per stage on a map of synthetic-room surfels.
//   bench_slam_predict [--surfels N] [--scale S] [--size 320x240] [--poses P] [--reps R] [--room NAME]
// Builds the map from frames of the synthetic sequence (noise on, 300 frames) spread over its
// trajectory: each frame is preprocessed and every pixel with a vertex and a normal becomes a surfel
// (world frame, fusion's radius sqrt(2) z / f / |cos(incidence)| with the factor capped at 4, the
// pixel's colour, last_seen = the frame; 3 in 4 stable), until
// the pool holds N surfels (default 300,000). Then predicts at P poses of the trajectory (default 30,
// spread evenly, frame index = the pose's frame, active window 200) R times each (default 5), and
// again R times with no tracking candidates (threshold above every confidence: the pass over the
// pool does the transform and the index map only). Prints, per stage, the median over the poses of
// each pose's fastest run (on a shared machine the fastest run is the least disturbed one), the
// median of every run as it came, and the counters. Thread CPU time is given beside the wall clock.
// One thread.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <time.h>

#include "io/frame_source.h"
#include "slam/model_prediction.h"
#include "slam/preprocess.h"
#include "slam/surfel_pool.h"
#include "synth/synthetic_source.h"

namespace {

// CPU time of the calling thread, milliseconds: unlike the wall clock, not inflated when other
// processes share the core.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}


// Surfels from one preprocessed frame (camera pose T_wc), at most `room` of them, spread over the
// image when fewer than the frame's pixels fit.
int64_t add_frame(ef::slam::SurfelPool& pool, const ef::slam::Preprocessor& pre, const ef::Frame& f, const ef::SE3& T_wc,
                  int32_t frame, int64_t room) {
  const ef::slam::PyramidLevel& l0 = pre.level(0);
  const ef::Intrinsics& K = l0.intrinsics;
  const Eigen::Matrix3f R = T_wc.rotation_matrix().cast<float>();
  int64_t added = 0;
  for (int y = 0; y < K.height && added < room; ++y)
    for (int x = 0; x < K.width && added < room; ++x) {
      const Eigen::Vector3f& v = l0.vertex(x, y);
      const Eigen::Vector3f& n = l0.normal(x, y);
      if (!ef::slam::valid_vertex(v) || !ef::slam::valid_normal(n)) continue;
      const Eigen::Vector3f p = T_wc * v;
      const Eigen::Vector3f nw = R * n;
      const ef::Rgb8 c = f.color(x, y);
      const float confidence = (x + y) % 4 == 0 ? 5.0f : 15.0f;
      // Fusion's radius: the pixel's footprint sqrt(2) z / f, over |cos(incidence)| capped at 4.
      const float cos_incidence = std::max(std::fabs(n.dot(v.normalized())), 0.25f);
      const float radius = std::sqrt(2.0f) * v.z() / K.fx / cos_incidence;
      if (pool.append(p.x(), p.y(), p.z(), nw.x(), nw.y(), nw.z(), radius, confidence,
                      ef::slam::pack_rgb(c.r, c.g, c.b), frame) >= 0)
        ++added;
    }
  return added;
}

}  // namespace

int main(int argc, char** argv) {
  int64_t surfels = 300'000;
  int scale = 4, width = 320, height = 240, poses = 30, reps = 5;
  std::string room = "living_room";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--surfels")) surfels = std::max<int64_t>(1, std::atoll(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--scale")) scale = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--poses")) poses = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--reps")) reps = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--room")) room = argv[i + 1];
    else if (!std::strcmp(argv[i], "--size") && std::sscanf(argv[i + 1], "%dx%d", &width, &height) != 2) {
      std::fprintf(stderr, "--size wants WxH\n");
      return 2;
    }
  }
  const int frames = 300;
  const std::string uri = "synthetic:" + room + "?noise=1&frames=" + std::to_string(frames) + "&size=" +
                          std::to_string(width) + "x" + std::to_string(height);
  auto parsed = ef::parse_source_uri(uri);
  if (!parsed.ok()) return 1;
  auto opts = ef::synth::parse_synthetic_options(*parsed);
  if (!opts.ok()) {
    std::fprintf(stderr, "%s\n", ef::to_string(opts.error()).c_str());
    return 1;
  }
  auto src = ef::synth::open_synthetic_source(*opts, uri);
  if (!src.ok()) return 1;
  ef::synth::SyntheticSource& source = **src;
  const ef::Intrinsics K = source.info().intrinsics;

  ef::slam::SurfelPoolOptions pool_options;
  pool_options.capacity = surfels;
  auto pool = ef::slam::SurfelPool::create(pool_options);
  auto pre = ef::slam::Preprocessor::create(K);
  if (!pool.ok() || !pre.ok()) return 1;
  ef::Frame f;
  f.allocate(K.width, K.height, true);
  // Frames in the order k * 37 mod 300 (37 is coprime with 300): spread over the whole trajectory
  // from the start, and every frame eventually, until the pool holds the surfels asked for.
  int used_frames = 0;
  for (int k = 0; k < frames && pool->size() < surfels; ++k) {
    const int index = (k * 37) % frames;
    if (!source.render(index, f).ok() || !pre->process(f).ok()) return 1;
    add_frame(*pool, *pre, f, source.poses()[index], index, surfels - pool->size());
    ++used_frames;
  }
  ef::slam::PredictionOptions po;
  po.index_map_scale = scale;
  auto created = ef::slam::ModelPredictor::create(K, 3, po);
  if (!created.ok()) {
    std::fprintf(stderr, "%s\n", ef::to_string(created.error()).c_str());
    return 1;
  }
  ef::slam::ModelPredictor& predictor = *created;
  (void)predictor.predict(*pool, source.poses()[0], 0);  // warm-up

  // Per pose: the fastest of its runs (the least disturbed by other processes on a shared machine),
  // per stage; reported: the median over the poses, and the median over every run as it came.
  struct Stages {
    double clear = 0, render = 0, resolve = 0, pyramid = 0, total = 0, cpu = 0, index_render = 0, index_cpu = 0;
  };
  std::vector<Stages> best;  // per pose
  std::vector<double> all_total, all_cpu;
  std::vector<double> index_surfels, candidates, splatted, valid;
  const auto keep_min = [](double& slot, double v, bool first) { slot = first ? v : std::min(slot, v); };
  for (int k = 0; k < poses; ++k) {
    const int index = k * (frames - 1) / std::max(1, poses - 1);
    Stages b;
    for (int r = 0; r < reps; ++r) {
      const double c0 = thread_cpu_ms();
      if (!predictor.predict(*pool, source.poses()[index], index).ok()) return 1;
      const double c = thread_cpu_ms() - c0;
      const ef::slam::PredictionTimings& t = predictor.timings();
      keep_min(b.clear, t.clear_ms, r == 0);
      keep_min(b.render, t.render_ms, r == 0);
      keep_min(b.resolve, t.resolve_ms, r == 0);
      keep_min(b.pyramid, t.pyramid_ms, r == 0);
      keep_min(b.total, t.total_ms, r == 0);
      keep_min(b.cpu, c, r == 0);
      all_total.push_back(t.total_ms);
      all_cpu.push_back(c);
    }
    const ef::slam::PredictionCounters& c = predictor.counters();
    index_surfels.push_back(static_cast<double>(c.index_surfels));
    candidates.push_back(static_cast<double>(c.tracking_candidates));
    splatted.push_back(static_cast<double>(c.splatted_surfels));
    valid.push_back(static_cast<double>(c.valid_pixels));
    for (int r = 0; r < reps; ++r) {
      const double c0 = thread_cpu_ms();
      if (!predictor.predict(*pool, source.poses()[index], index, 1e30f).ok()) return 1;
      keep_min(b.index_cpu, thread_cpu_ms() - c0, r == 0);
      keep_min(b.index_render, predictor.timings().render_ms, r == 0);
    }
    best.push_back(b);
  }
  const auto over_poses = [&](double Stages::*field) {
    std::vector<double> v;
    for (const Stages& b : best) v.push_back(b.*field);
    return median(v);
  };
  std::printf("ModelPredictor at %dx%d, 3 levels, index map %dx (%dx%d); %lld surfels from %d frames of %s; "
              "%d poses x %d runs: median over poses of each pose's fastest run\n",
              K.width, K.height, scale, K.width * scale, K.height * scale, static_cast<long long>(pool->size()),
              used_frames, uri.c_str(), poses, reps);
  std::printf("  %-46s %8.3f ms\n", "clear (index map, level-0 buffers)", over_poses(&Stages::clear));
  std::printf("  %-46s %8.3f ms\n", "render (pass over the pool)", over_poses(&Stages::render));
  std::printf("  %-46s %8.3f ms\n", "resolve (level-0 maps)", over_poses(&Stages::resolve));
  std::printf("  %-46s %8.3f ms\n", "pyramid (coarse levels, gradients, holes)", over_poses(&Stages::pyramid));
  std::printf("  %-46s %8.3f ms\n", "total, wall clock", over_poses(&Stages::total));
  std::printf("  %-46s %8.3f ms\n", "total, thread CPU time", over_poses(&Stages::cpu));
  std::printf("  %-46s %8.3f ms\n", "index map only: render (transform + scatter)", over_poses(&Stages::index_render));
  std::printf("  %-46s %8.3f ms\n", "index map only: total, thread CPU time", over_poses(&Stages::index_cpu));
  std::printf("  every run as it came (median): total %.3f ms wall clock, %.3f ms thread CPU time\n", median(all_total),
              median(all_cpu));
  std::printf("  per pose (median): %.0f surfels in the index map, %.0f tracking candidates, %.0f splatted, "
              "%.0f valid level-0 pixels of %d\n",
              median(index_surfels), median(candidates), median(splatted), median(valid), K.width * K.height);
  return 0;
}
