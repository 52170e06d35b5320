// The dense CRF over a surfel map (issue 6 goal: 10 mean-field iterations over 500,000 surfels in at
// most 1 s on one core; the paper: 20.3 s).
//   bench_crf [--surfels N] [--reps R] [--iterations K] [--max-vertices V] [--sort 0|1] [--calibration S]
//             [--source URI | --checkpoint RUN_DIR] [--min-confidence C] [--dump-labels FILE]
// --checkpoint: the map of a finished `edgefusion run` instead (its checkpoint.efs, as `edgefusion
// export` reads it): a real map built by SurfelSlam with the labels it fused, e.g. the 7-Scenes
// kitchen's (issue 31); --surfels and --source are then unused. --min-confidence: DenseCrfOptions::
// min_confidence (default 10: the stable surfels; the sampled map's surfels all have 20).
// The map: frames of the synthetic source (default synthetic:?size=320x240&noise=0, the built-in
// living room on its hand-held loop, noise-free: a fused map's colours and normals are averages over
// many frames, which single noisy frames are not) back-projected with their exact poses, one surfel
// per pixel with the pixel's colour, a normal from the depth 3 pixels either side and its true class
// as a CNN-like distribution (the true class at probability 0.4-0.8, a random class instead for one
// pixel in five), keeping one surfel per 6 mm voxel, frames taken in a stride of 7 over the sequence
// until N surfels (default 500,000). This is a map sampled on the room's surfaces, not one built by
// SurfelSlam (which would take minutes to reach 500k surfels here). --sort 1 reorders the pool by
// 10 cm cells first (the CRF sorts internally anyway; this shows what a spatially ordered pool gains).
// Prints the median (and best) over R runs (default 5) of DenseCrf::run with K iterations and with
// one: thread CPU ms of the whole run and the wall ms of its two parts (lattice build; the rest),
// and the cost of one iteration as the difference of the two thread CPU medians over K - 1; the
// lattice vertex counts and the memory. Labels are restored before every run. Pin the CPU
// (taskset -c 1); one thread. --dump-labels writes the label store after the last K-iteration run
// (16 bytes per surfel, pool order), to compare the CRF's results across builds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <unordered_set>
#include <vector>

#include "bench_timing.h"
#include "core/frame.h"
#include "io/frame_source.h"
#include "kernels/crf_rows.h"
#include "pipeline/checkpoint.h"
#include "platform/cpu/cpu_features.h"
#include "semantic/dense_crf.h"
#include "semantic/label_store.h"
#include "slam/surfel_pool.h"
#include "synth/synthetic_source.h"

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The CRF runs over `map` and their report (below main).
int run_crf(ef::slam::SurfelPool& map, int reps, int iterations, int64_t max_vertices, int calibration,
            float min_confidence, const std::string& dump_path);

}  // namespace

int main(int argc, char** argv) {
  using namespace ef;
  int64_t target = 500'000;
  int reps = 5, iterations = 10;
  int64_t max_vertices = 0;  // DenseCrfOptions::max_lattice_vertices (0 = derived)
  bool sort_map = false;
  int calibration = semantic::DenseCrfOptions{}.calibration_samples;
  std::string uri = "synthetic:?size=320x240&noise=0";
  std::string dump_path, checkpoint_dir;
  float min_confidence = semantic::DenseCrfOptions{}.min_confidence;  // DenseCrfOptions::min_confidence
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--surfels")) target = std::atoll(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--reps")) reps = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--iterations")) iterations = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--source")) uri = argv[i + 1];
    else if (!std::strcmp(argv[i], "--max-vertices")) max_vertices = std::atoll(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--sort")) sort_map = std::atoi(argv[i + 1]) != 0;
    else if (!std::strcmp(argv[i], "--calibration")) calibration = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--dump-labels")) dump_path = argv[i + 1];
    else if (!std::strcmp(argv[i], "--checkpoint")) checkpoint_dir = argv[i + 1];
    else if (!std::strcmp(argv[i], "--min-confidence")) min_confidence = static_cast<float>(std::atof(argv[i + 1]));
    else {
      std::fprintf(stderr, "unknown option %s\n", argv[i]);
      return 2;
    }
  }
  if (!checkpoint_dir.empty()) {
    auto found = pipeline::find_checkpoint(checkpoint_dir);
    if (!found.ok()) {
      std::fprintf(stderr, "bench_crf: %s\n", to_string(found.error()).c_str());
      return 2;
    }
    auto loaded = pipeline::load_checkpoint_pool(*found);
    if (!loaded.ok()) {
      std::fprintf(stderr, "bench_crf: %s\n", to_string(loaded.error()).c_str());
      return 2;
    }
    std::printf("dense crf: the map of the run in %s: %lld surfels (frame %lld of its source)\n", checkpoint_dir.c_str(),
                static_cast<long long>(loaded->size()), static_cast<long long>(found->meta.frames));
    return run_crf(*loaded, reps, iterations, max_vertices, calibration, min_confidence, dump_path);
  }
  auto parsed = parse_source_uri(uri);
  if (!parsed.ok() || parsed->scheme != "synthetic") {
    std::fprintf(stderr, "bench_crf: --source must be a synthetic: URI\n");
    return 2;
  }
  auto options = synth::parse_synthetic_options(*parsed);
  if (!options.ok()) {
    std::fprintf(stderr, "%s\n", to_string(options.error()).c_str());
    return 2;
  }
  auto source = synth::open_synthetic_source(*options, uri);
  if (!source.ok()) {
    std::fprintf(stderr, "%s\n", to_string(source.error()).c_str());
    return 2;
  }
  const SourceInfo& info = (*source)->info();
  slam::SurfelPoolOptions po;
  po.capacity = target;
  auto pool = slam::SurfelPool::create(po);
  if (!pool.ok()) return 1;

  // Frames in a stride over the sequence (all of them if needed), one surfel per voxel.
  const int64_t frames = info.frame_count > 0 ? info.frame_count : 300;
  const double t_map = bench::thread_cpu_seconds();
  std::unordered_set<uint64_t> voxels;
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> conf(0.4f, 0.8f), unit(0.0f, 1.0f);
  const float voxel = 0.006f;
  Frame f;
  int64_t frames_used = 0;
  const int64_t stride = 7;  // coprime with the default 300 frames: visits every frame eventually
  for (int64_t step = 0; step < frames && pool->size() < target; ++step) {
    if (!(*source)->render((step * stride) % frames, f).ok()) return 1;
    ++frames_used;
    const Intrinsics& K = info.intrinsics;
    const int W = f.depth.width(), H = f.depth.height();
    // Normals from the depth 3 pixels either side (a surfel map's normals are averaged over many
    // observations; single-pixel differences of noisy depth would not be).
    constexpr int r = 3;
    for (int v = r; v + r < H && pool->size() < target; ++v)
      for (int u = r; u + r < W && pool->size() < target; ++u) {
        const float z = f.depth(u, v), zl = f.depth(u - r, v), zr = f.depth(u + r, v), zu = f.depth(u, v - r),
                    zd = f.depth(u, v + r);
        if (!(z > 0) || !(zl > 0) || !(zr > 0) || !(zu > 0) || !(zd > 0)) continue;
        const Eigen::Vector3f p = K.backproject(float(u), float(v), z);
        const Eigen::Vector3f dx =
            K.backproject(float(u + r), float(v), zr) - K.backproject(float(u - r), float(v), zl);
        const Eigen::Vector3f dy =
            K.backproject(float(u), float(v + r), zd) - K.backproject(float(u), float(v - r), zu);
        if (dx.norm() > 0.1f || dy.norm() > 0.1f) continue;  // a depth edge: no reliable normal
        Eigen::Vector3f n = dx.cross(dy);
        if (!(n.norm() > 0)) continue;
        n.normalize();
        if (n.dot(p) > 0) n = -n;  // towards the camera
        const Eigen::Vector3f pw = f.T_wc * p;
        const Eigen::Vector3f nw = (f.T_wc.rotation().cast<float>() * n).normalized();
        const auto key = [&](float c) { return uint64_t(int64_t(std::floor(c / voxel)) & 0x1FFFFF); };
        if (!voxels.insert(key(pw.x()) | key(pw.y()) << 21 | key(pw.z()) << 42).second) continue;
        const Rgb8 c = f.color(u, v);
        const int64_t id = pool->append(pw.x(), pw.y(), pw.z(), nw.x(), nw.y(), nw.z(), 0.004f, 20,
                                        slam::pack_rgb(c.r, c.g, c.b), int32_t(f.index));
        float probs[semantic::kLabelClasses];
        const int truth = unit(rng) < 0.2f ? int(rng() % semantic::kLabelClasses) : int(f.labels(u, v));
        const float p_true = conf(rng);
        for (int cls = 0; cls < semantic::kLabelClasses; ++cls)
          probs[cls] = cls == truth ? p_true : (1.0f - p_true) / float(semantic::kLabelClasses - 1);
        semantic::encode_labels(probs, pool->labels() + id * semantic::kLabelBytes);
      }
  }
  if (sort_map) {
    // Surfels in the order of 10 cm cells (x fastest), as a map compacted by space would hold them.
    const int64_t n = pool->size();
    std::vector<std::pair<uint64_t, int64_t>> order(static_cast<std::size_t>(n));
    for (int64_t i = 0; i < n; ++i) {
      const auto cell = [](float c) { return uint64_t(int64_t(std::floor(c / 0.1f)) + 1000); };
      order[std::size_t(i)] = {(cell(pool->z()[i]) << 40) | (cell(pool->y()[i]) << 20) | cell(pool->x()[i]), i};
    }
    std::sort(order.begin(), order.end());
    auto sorted = slam::SurfelPool::create(po);
    if (!sorted.ok()) return 1;
    for (const auto& [key, i] : order) {
      const int64_t id = sorted->append(pool->x()[i], pool->y()[i], pool->z()[i], pool->nx()[i], pool->ny()[i],
                                        pool->nz()[i], pool->radius()[i], pool->confidence()[i], pool->color()[i],
                                        pool->init_time()[i]);
      std::memcpy(sorted->labels() + id * semantic::kLabelBytes, pool->labels() + i * semantic::kLabelBytes,
                  semantic::kLabelBytes);
    }
    *pool = std::move(*sorted);
  }
  const double map_s = bench::thread_cpu_seconds() - t_map;
  std::printf("dense crf: map of %lld surfels sampled from %lld frames of %s (exact poses, one surfel per %.0f mm "
              "voxel, %.1f s to build); wanted %lld\n",
              static_cast<long long>(pool->size()), static_cast<long long>(frames_used), uri.c_str(), voxel * 1e3,
              map_s, static_cast<long long>(target));
  return run_crf(*pool, reps, iterations, max_vertices, calibration, min_confidence, dump_path);
}

namespace {

int run_crf(ef::slam::SurfelPool& map, int reps, int iterations, int64_t max_vertices, int calibration,
            float min_confidence, const std::string& dump_path) {
  using namespace ef;
  slam::SurfelPool* pool = &map;
  std::printf("cpu: %s; one thread; lattice rows: %s\n", cpu_features().describe().c_str(),
              kernels::crf_rows_selected());

  semantic::DenseCrfOptions o;
  o.capacity = pool->size();
  o.iterations = iterations;
  o.max_lattice_vertices = max_vertices;
  o.calibration_samples = calibration;
  o.min_confidence = min_confidence;
  semantic::DenseCrfOptions one = o;  // the same with one iteration: the fixed part of a run
  one.iterations = 1;
  auto crf = semantic::DenseCrf::create(o);
  auto crf_one = semantic::DenseCrf::create(one);
  if (!crf.ok() || !crf_one.ok()) {
    std::fprintf(stderr, "%s\n", to_string(crf.ok() ? crf_one.error() : crf.error()).c_str());
    return 1;
  }
  std::printf("options: %s\n", o.describe().c_str());
  std::printf("memory: %.1f MB (%zu bytes per surfel of capacity, %zu per lattice vertex)\n",
              double(crf->bytes()) / 1e6, semantic::DenseCrf::kBytesPerSurfel, semantic::DenseCrf::kBytesPerVertex);

  const std::vector<uint8_t> labels(pool->labels(), pool->labels() + pool->size() * semantic::kLabelBytes);
  struct Series {
    std::vector<double> cpu_ms, build_ms, iterate_ms;
    semantic::DenseCrfStats last;
  };
  auto measure = [&](semantic::DenseCrf& c, Series& out) {
    for (int r = 0; r < std::max(reps, 1); ++r) {
      std::memcpy(pool->labels(), labels.data(), labels.size());
      const double t0 = bench::thread_cpu_seconds();
      auto stats = c.run(*pool);
      const double t1 = bench::thread_cpu_seconds();
      if (!stats.ok()) {
        std::fprintf(stderr, "%s\n", to_string(stats.error()).c_str());
        return false;
      }
      out.last = *stats;
      out.cpu_ms.push_back((t1 - t0) * 1e3);
      out.build_ms.push_back(stats->build_ms);
      out.iterate_ms.push_back(stats->iterate_ms);
    }
    return true;
  };
  Series k_iter, one_iter;
  if (!measure(*crf_one, one_iter) || !measure(*crf, k_iter)) return 1;
  int64_t changed = 0;  // by the last run (K iterations)
  for (int64_t i = 0; i < pool->size(); ++i)
    changed += semantic::label_argmax(pool->labels() + i * semantic::kLabelBytes) !=
               semantic::label_argmax(labels.data() + i * semantic::kLabelBytes);
  const semantic::DenseCrfStats& last = k_iter.last;
  const double nodes = double(std::max<int64_t>(1, last.surfels - last.surfels_unconfident));
  std::printf("nodes: %lld of %lld surfels (%lld below confidence %.1f)\n",
              static_cast<long long>(last.surfels - last.surfels_unconfident), static_cast<long long>(last.surfels),
              static_cast<long long>(last.surfels_unconfident), double(min_confidence));
  std::printf("lattice vertices: bilateral %lld (%.3f per node), spatial %lld (%.3f per node); nodes left "
              "out %lld\n",
              static_cast<long long>(last.bilateral_vertices), double(last.bilateral_vertices) / nodes,
              static_cast<long long>(last.spatial_vertices), double(last.spatial_vertices) / nodes,
              static_cast<long long>(last.surfels_left_out));
  auto best = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  std::printf("median of %d runs (best in brackets):\n", std::max(reps, 1));
  std::printf("  run(), %2d iterations   %8.1f ms thread CPU (%.1f); wall: lattice build %.1f (%.1f), the rest %.1f "
              "(%.1f)\n",
              iterations, median(k_iter.cpu_ms), best(k_iter.cpu_ms), median(k_iter.build_ms), best(k_iter.build_ms),
              median(k_iter.iterate_ms), best(k_iter.iterate_ms));
  std::printf("  run(),  1 iteration    %8.1f ms thread CPU (%.1f); wall: lattice build %.1f (%.1f), the rest %.1f "
              "(%.1f)\n",
              median(one_iter.cpu_ms), best(one_iter.cpu_ms), median(one_iter.build_ms), best(one_iter.build_ms),
              median(one_iter.iterate_ms), best(one_iter.iterate_ms));
  if (iterations > 1) {
    const double per = (median(k_iter.cpu_ms) - median(one_iter.cpu_ms)) / double(iterations - 1);
    std::printf("  one iteration          %8.1f ms thread CPU (difference of the medians / %d); %d iterations %.1f "
                "ms\n",
                per, iterations - 1, iterations, per * iterations);
  }
  std::printf("  the rest = Q initialisation, first filter, scale calibration, iterations, write-back "
              "(encode_labels)\n");
  std::printf("scale corrections (exact / lattice kernel sums): bilateral %.2f, spatial %.2f\n",
              double(last.bilateral_scale_correction), double(last.spatial_scale_correction));
  std::printf("argmax changed by the CRF: %lld surfels (%.1f%%)\n", static_cast<long long>(changed),
              100.0 * double(changed) / double(pool->size()));
  if (!dump_path.empty()) {
    std::FILE* out = std::fopen(dump_path.c_str(), "wb");
    const std::size_t bytes = std::size_t(pool->size()) * semantic::kLabelBytes;
    if (!out || std::fwrite(pool->labels(), 1, bytes, out) != bytes || std::fclose(out) != 0) {
      std::fprintf(stderr, "bench_crf: cannot write %s\n", dump_path.c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace
