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
template <bool kInterior>
float coarse_depth_at(const Image<float>& fine, int x, int y, float thr) {
  const int fw = fine.width(), fh = fine.height();
  const float* r0 = fine.data() + static_cast<std::size_t>(2 * y) * fw + 2 * x;
  const float block[4] = {r0[0], r0[1], r0[fw], r0[fw + 1]};
  float nearest = kInf;
  for (float d : block) nearest = std::min(nearest, d > 0.0f ? d : kInf);
  if (nearest == kInf) return 0.0f;
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
  return weight > 0.0f ? sum / weight : ref;
}

}  // namespace

void downsample_depth(const Image<float>& fine, Image<float>& coarse, float threshold_m) {
  for_each_pixel(coarse.width(), coarse.height(), [&](int x, int y, bool interior) {
    coarse(x, y) = interior ? coarse_depth_at<true>(fine, x, y, threshold_m)
                            : coarse_depth_at<false>(fine, x, y, threshold_m);
  });
}

}  // namespace ef::slam
