// Times slam::Preprocessor per stage at the working resolution.
//   bench_slam_preprocess [--frames N] [--reps R] [--size 320x240]
// Reads the first N frames (default 30) of 7-Scenes redkitchen from the shared data (synthetic tilted
// planes with noise when it is absent), resamples them to the working size, then processes each frame
// R times (default 5); prints the median milliseconds per stage over all runs. One thread.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <vector>

#include "io/frame_resample.h"
#include "slam/preprocess.h"
#include "sources/open_source.h"

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// A noisy tilted plane with a box in front (step edges), for when no dataset is available.
void synthetic_frame(ef::Frame& f, const ef::Intrinsics& K, int i) {
  std::mt19937 rng(static_cast<unsigned>(i));
  std::normal_distribution<float> noise(0.0f, 0.004f);
  for (int y = 0; y < K.height; ++y)
    for (int x = 0; x < K.width; ++x) {
      float z = 1.5f + 0.004f * static_cast<float>(x) + 0.002f * static_cast<float>(y + i);
      if (x > K.width / 3 && x < K.width / 2 && y > K.height / 3) z = 1.0f;
      f.depth(x, y) = (x + y) % 97 == 0 ? 0.0f : z + noise(rng);
      const uint8_t g = static_cast<uint8_t>((x * 3 + y * 5 + i) & 255);
      f.color(x, y) = ef::Rgb8{g, static_cast<uint8_t>(255 - g), 128};
    }
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 30, reps = 5, width = 320, height = 240;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--frames")) frames = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--reps")) reps = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--size") && std::sscanf(argv[i + 1], "%dx%d", &width, &height) != 2) {
      std::fprintf(stderr, "--size wants WxH\n");
      return 2;
    }
  }
  std::vector<ef::Frame> work;
  ef::Intrinsics K;
  const char* env = std::getenv("EF_SHARED_DATA");
  const std::filesystem::path data = std::filesystem::path(env && *env ? env : EF_SHARED_DATA_DIR) / "7scenes-redkitchen";
  std::string what;
  if (std::filesystem::is_directory(data)) {
    auto src = ef::open_source("7scenes:" + data.string());
    if (!src.ok()) {
      std::fprintf(stderr, "%s\n", ef::to_string(src.error()).c_str());
      return 1;
    }
    K = (*src)->info().intrinsics.scaled_to(width, height);
    ef::Frame full;
    for (int i = 0; i < frames; ++i) {
      auto got = (*src)->next(full);
      if (!got.ok() || !*got) break;
      work.emplace_back();
      work.back().allocate(width, height, false);
      ef::resample_frame(full, work.back());
    }
    what = "7-Scenes redkitchen frames 0.." + std::to_string(work.size() - 1);
  } else {
    K = ef::Intrinsics{585, 585, 320, 240, 640, 480}.scaled_to(width, height);
    for (int i = 0; i < frames; ++i) {
      work.emplace_back();
      work.back().allocate(width, height, false);
      synthetic_frame(work.back(), K, i);
    }
    what = "synthetic planes (no 7-Scenes data at " + data.string() + ")";
  }
  auto created = ef::slam::Preprocessor::create(K);
  if (!created.ok()) {
    std::fprintf(stderr, "%s\n", ef::to_string(created.error()).c_str());
    return 1;
  }
  ef::slam::Preprocessor& p = *created;
  (void)p.process(work[0]);  // warm-up
  std::vector<double> bil, pyr, vn, inten, total;
  for (const ef::Frame& f : work)
    for (int r = 0; r < reps; ++r) {
      if (!p.process(f).ok()) return 1;
      const ef::slam::PreprocessTimings& t = p.timings();
      bil.push_back(t.bilateral_ms);
      pyr.push_back(t.depth_pyramid_ms);
      vn.push_back(t.vertex_normal_ms);
      inten.push_back(t.intensity_ms);
      total.push_back(t.total_ms);
    }
  std::printf("Preprocessor at %dx%d, %d levels, bilateral %dx%d; %s; %zu runs (median ms)\n", width, height,
              p.levels(), 2 * p.options().bilateral_radius_px + 1, 2 * p.options().bilateral_radius_px + 1,
              what.c_str(), total.size());
  std::printf("  %-34s %8.3f ms\n", "cut-off + bilateral (level 0)", median(bil));
  std::printf("  %-34s %8.3f ms\n", "depth pyramid (levels 1..)", median(pyr));
  std::printf("  %-34s %8.3f ms\n", "vertex + normal maps (all levels)", median(vn));
  std::printf("  %-34s %8.3f ms\n", "intensity, pyramid, gradients", median(inten));
  std::printf("  %-34s %8.3f ms\n", "total", median(total));
  return 0;
}
