// The coarse depth rule of slam/depth_pyramid.h.
#include "slam/depth_pyramid.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/pyramid_row.h"

namespace ef::slam {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kTap[4] = {1.0f, 3.0f, 3.0f, 1.0f};  // binomial weights of the 4x4 window, per axis

// Coarse depth at (x, y) of a border pixel (taps outside the finer image are skipped): the rule of
// kernels/pyramid_row.h, whose kernel does the interior pixels. A block without depth runs through
// with ref = NaN, which no tap takes, and gives 0 at the end.
float coarse_depth_at(const Image<float>& fine, int x, int y, float thr) {
  const int fw = fine.width(), fh = fine.height();
  const float* r0 = fine.data() + static_cast<std::size_t>(2 * y) * fw + 2 * x;
  const float block[4] = {r0[0], r0[1], r0[fw], r0[fw + 1]};
  float nearest = kInf;
  for (float d : block) nearest = std::min(nearest, d > 0.0f ? d : kInf);
  const bool any = nearest != kInf;
  float ref_sum = 0.0f, ref_n = 0.0f;
  for (float d : block) {
    const bool near_surface = (d > 0.0f) & (d <= nearest + thr);
    ref_sum += near_surface ? d : 0.0f;
    ref_n += near_surface ? 1.0f : 0.0f;
  }
  const float ref = ref_sum / ref_n;
  float sum = 0.0f, weight = 0.0f;
  for (int j = 0; j < 4; ++j) {
    const int yy = 2 * y - 1 + j;
    if (yy < 0 || yy >= fh) continue;
    const float* row = fine.data() + static_cast<std::size_t>(yy) * fw;
    for (int i = 0; i < 4; ++i) {
      const int xx = 2 * x - 1 + i;
      if (xx < 0 || xx >= fw) continue;
      const float d = row[xx];
      const bool take = (d > 0.0f) & (std::fabs(d - ref) <= thr);
      const float wgt = kTap[i] * kTap[j];
      sum += take ? wgt * d : 0.0f;
      weight += take ? wgt : 0.0f;
    }
  }
  // The block's near-surface depths lie within thr of their mean, so weight > 0 but for rounding.
  const float depth = weight > 0.0f ? sum / weight : ref;
  return any ? depth : 0.0f;
}

// Coarse intensity at (x, y) of a pixel that has a coarse depth: the binomial window over the finer
// pixels with depth; 0 when none (the border pixels of downsample(); the interior is the kernel's).
float coarse_intensity_at(const Image<float>& depth, const Image<float>& intensity, int x, int y) {
  const int fw = depth.width(), fh = depth.height();
  float sum = 0.0f, weight = 0.0f;
  for (int j = 0; j < 4; ++j) {
    const int yy = 2 * y - 1 + j;
    if (yy < 0 || yy >= fh) continue;
    const float* d = depth.data() + static_cast<std::size_t>(yy) * fw;
    const float* g = intensity.data() + static_cast<std::size_t>(yy) * fw;
    for (int i = 0; i < 4; ++i) {
      const int xx = 2 * x - 1 + i;
      if (xx < 0 || xx >= fw) continue;
      const bool take = d[xx] > 0.0f;
      const float wgt = kTap[i] * kTap[j];
      sum += take ? wgt * g[xx] : 0.0f;
      weight += take ? wgt : 0.0f;
    }
  }
  return weight > 0.0f ? sum / weight : 0.0f;
}

// Both downsamples: the interior pixels of rows 1 .. h - 2 by kernels/pyramid_row (SIMD across the
// row, bit-identical to its scalar twin, which states the same rule), the border pixels here.
void downsample(const Image<float>& fine, const Image<float>* fine_intensity, Image<float>& coarse,
                Image<float>* coarse_intensity, float threshold_m) {
  const int w = coarse.width(), h = coarse.height(), fw = fine.width();
  const auto border = [&](int x, int y) {
    const float d = coarse_depth_at(fine, x, y, threshold_m);
    coarse(x, y) = d;
    if (coarse_intensity != nullptr)
      (*coarse_intensity)(x, y) = d > 0.0f ? coarse_intensity_at(fine, *fine_intensity, x, y) : 0.0f;
  };
  kernels::PyramidRow row;
  row.threshold_m = threshold_m;
  for (int y = 0; y < h; ++y) {
    if (y == 0 || y == h - 1 || w < 3) {
      for (int x = 0; x < w; ++x) border(x, y);
      continue;
    }
    border(0, y);
    for (int j = 0; j < 4; ++j) {
      const std::size_t r = static_cast<std::size_t>(2 * y - 1 + j) * fw;
      row.depth[j] = fine.data() + r;
      if (coarse_intensity != nullptr) row.intensity[j] = fine_intensity->data() + r;
    }
    kernels::pyramid_row(row, 1, w - 1, &coarse(0, y), coarse_intensity != nullptr ? &(*coarse_intensity)(0, y) : nullptr);
    border(w - 1, y);
  }
}

}  // namespace

void downsample_depth(const Image<float>& fine, Image<float>& coarse, float threshold_m) {
  downsample(fine, nullptr, coarse, nullptr, threshold_m);
}

void downsample_depth_intensity(const Image<float>& fine_depth, const Image<float>& fine_intensity,
                                Image<float>& coarse_depth, Image<float>& coarse_intensity, float threshold_m) {
  downsample(fine_depth, &fine_intensity, coarse_depth, &coarse_intensity, threshold_m);
}

}  // namespace ef::slam
