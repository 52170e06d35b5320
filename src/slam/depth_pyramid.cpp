// The coarse depth rule of slam/depth_pyramid.h.
#include "slam/depth_pyramid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ef::slam {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kTap[4] = {1.0f, 3.0f, 3.0f, 1.0f};  // binomial weights of the 4x4 window, per axis

// Coarse depth at (x, y), written once for a pixel whose window lies inside the finer image
// (kInterior: no bounds tests) and for a border pixel (taps outside the image are skipped).
// Branch-free (only selects): a block without depth runs through with ref = NaN, which no tap
// takes, and gives 0 at the end; so a row of interior pixels is one loop the compiler vectorises.
template <bool kInterior>
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
    if (!kInterior && (yy < 0 || yy >= fh)) continue;
    const float* row = fine.data() + static_cast<std::size_t>(yy) * fw;
    for (int i = 0; i < 4; ++i) {
      const int xx = 2 * x - 1 + i;
      if (!kInterior && (xx < 0 || xx >= fw)) continue;
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

}  // namespace

void downsample_depth(const Image<float>& fine, Image<float>& coarse, float threshold_m) {
  const int w = coarse.width(), h = coarse.height();
  for (int y = 0; y < h; ++y) {
    float* out = &coarse(0, y);
    if (y == 0 || y == h - 1) {
      for (int x = 0; x < w; ++x) out[x] = coarse_depth_at<false>(fine, x, y, threshold_m);
      continue;
    }
    out[0] = coarse_depth_at<false>(fine, 0, y, threshold_m);
    for (int x = 1; x < w - 1; ++x) out[x] = coarse_depth_at<true>(fine, x, y, threshold_m);
    out[w - 1] = coarse_depth_at<false>(fine, w - 1, y, threshold_m);
  }
}

}  // namespace ef::slam
