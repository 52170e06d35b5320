// One Bayesian label update at 320x240 (issue 6 target: at most 2 ms on one core).
//   bench_label_update [--reps R] [--min-ms T]
// Setup: a 1,000,000-surfel pool, an index map of scale 4 (1280x960 cells) holding 76,800 surfels
// (one per working pixel, at a random sub-cell, random distinct ids), CNN probabilities 160x120x14.
// Prints the median thread-CPU ms per update of (a) the update kernel alone on the fused pair list,
// per variant this CPU can run, and (b) the whole LabelFusion::fuse() (observation vectors with
// a fast log for 19,200 CNN pixels, index-map walk, dispatched kernel), and (c) fuse() on an empty
// index map (observations and walk only). Pin the CPU; note the load.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "bench_timing.h"
#include "kernels/label_update_variants.h"
#include "platform/cpu/cpu_features.h"
#include "semantic/label_fusion.h"
#include "semantic/label_store.h"
#include "slam/index_map.h"
#include "slam/surfel_pool.h"

int main(int argc, char** argv) {
  int reps = 15;
  double min_ms = 100;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--reps")) reps = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--min-ms")) min_ms = std::atof(argv[i + 1]);
  }
  using namespace ef;
  constexpr int kW = 320, kH = 240, kScale = 4, kCw = 160, kCh = 120;
  constexpr int64_t kPool = 1'000'000;
  slam::SurfelPoolOptions po;
  po.capacity = kPool;
  auto pool = slam::SurfelPool::create(po);
  if (!pool.ok()) return 1;
  for (int64_t i = 0; i < kPool; ++i) pool->append(0, 0, 1, 0, 0, -1, 0.01f, 1, 0, 0);

  std::mt19937 rng(6);
  std::vector<int32_t> ids(static_cast<std::size_t>(kPool));
  std::iota(ids.begin(), ids.end(), 0);
  std::shuffle(ids.begin(), ids.end(), rng);
  slam::IndexMap index;
  index.scale = kScale;
  index.id.allocate(kW * kScale, kH * kScale);
  index.id.fill(-1);
  std::size_t next = 0;
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
      index.id(u * kScale + int(rng() % kScale), v * kScale + int(rng() % kScale)) = ids[next++];

  std::vector<float> probs(std::size_t(kCw) * kCh * semantic::kLabelClasses);
  for (std::size_t p = 0; p < probs.size(); p += semantic::kLabelClasses) {
    float sum = 0;
    for (int c = 0; c < semantic::kLabelClasses; ++c) sum += (probs[p + c] = 0.001f + float(rng() % 1000));
    for (int c = 0; c < semantic::kLabelClasses; ++c) probs[p + c] /= sum;
  }
  const semantic::ProbabilityView view{probs.data(), kCh, kCw, semantic::kLabelClasses};
  semantic::LabelFusionOptions fo;
  auto fusion = semantic::LabelFusion::create(fo);
  if (!fusion.ok()) return 1;
  auto first = fusion->fuse(index, view, *pool);
  if (!first.ok()) return 1;

  // The pair list fuse() builds, rebuilt here for the kernel-only timing.
  std::vector<kernels::LabelUpdatePair> pairs;
  for (int y = 0; y < kH * kScale; ++y)
    for (int x = 0; x < kW * kScale; ++x) {
      const int32_t id = index.id(x, y);
      if (id < 0) continue;
      const int cx = int(((2 * (x / kScale) + 1) * kCw) / (2 * kW)), cy = int(((2 * (y / kScale) + 1) * kCh) / (2 * kH));
      pairs.push_back({id, cy * kCw + cx});
    }
  std::printf("label update: pool %lld surfels, index map %dx%d (scale %d), %zu visible surfels, cnn %dx%d\n",
              static_cast<long long>(kPool), kW * kScale, kH * kScale, kScale, pairs.size(), kCw, kCh);
  std::printf("cpu: %s; thread CPU time, median of %d runs of >= %.0f ms\n", cpu_features().describe().c_str(), reps,
              min_ms);
  for (const auto& v : kernels::kLabelUpdateVariants) {
    if (!kernels::isa_available(v.isa, detected_cpu_features())) {
      std::printf("  %-28s skipped (no %s)\n", v.name, kernels::isa_name(v.isa));
      continue;
    }
    const auto t = bench::time_calls([&] { v.fn(pool->labels(), fusion->observations(), pairs.data(), pairs.size()); },
                                     reps, min_ms);
    std::printf("  %-28s %8.3f ms per update (best %.3f, iqr %.0f%%)\n", v.name, t.median * 1e3, t.best * 1e3,
                t.iqr * 100);
  }
  const auto t = bench::time_calls([&] { (void)fusion->fuse(index, view, *pool); }, reps, min_ms);
  std::printf("  %-28s %8.3f ms per update (best %.3f, iqr %.0f%%; kernel %s)\n", "LabelFusion::fuse", t.median * 1e3,
              t.best * 1e3, t.iqr * 100, kernels::label_update_selected());
  // The same without any visible surfel: the observation vectors and the index-map walk alone.
  slam::IndexMap empty;
  empty.scale = kScale;
  empty.id.allocate(kW * kScale, kH * kScale);
  empty.id.fill(-1);
  const auto te = bench::time_calls([&] { (void)fusion->fuse(empty, view, *pool); }, reps, min_ms);
  std::printf("  %-28s %8.3f ms per update (best %.3f, iqr %.0f%%)\n", "fuse, nothing visible", te.median * 1e3,
              te.best * 1e3, te.iqr * 100);
  return 0;
}
