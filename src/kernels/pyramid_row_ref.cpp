// pyramid_row, scalar reference (the specification; see kernels/pyramid_row.h).
#include <cmath>
#include <limits>

#include "kernels/pyramid_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void pyramid_row_ref(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kTap[4] = {1.0f, 3.0f, 3.0f, 1.0f};
  const float thr = r.threshold_m;
  const bool with_intensity = r.intensity[0] != nullptr;
  for (int x = x_begin; x < x_end; ++x) {
    const int c = 2 * x - 1;  // the window's first column
    const float block[4] = {r.depth[1][c + 1], r.depth[1][c + 2], r.depth[2][c + 1], r.depth[2][c + 2]};
    float nearest = kInf;
    for (float d : block) {
      const float v = d > 0.0f ? d : kInf;
      nearest = v < nearest ? v : nearest;
    }
    float rs = 0.0f, rn = 0.0f;
    for (float d : block) {
      const bool near_surface = (d > 0.0f) & (d <= nearest + thr);
      rs = rs + (near_surface ? d : 0.0f);
      rn = rn + (near_surface ? 1.0f : 0.0f);
    }
    const float ref = rs / rn;
    float s = 0.0f, wt = 0.0f;
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const float d = r.depth[j][c + i];
        const float w = kTap[i] * kTap[j];
        const bool take = (d > 0.0f) & (std::fabs(d - ref) <= thr);
        s = s + (take ? w * d : 0.0f);
        wt = wt + (take ? w : 0.0f);
      }
    const float depth = nearest != kInf ? (wt > 0.0f ? s / wt : ref) : 0.0f;
    depth_out[x] = depth;
    if (!with_intensity) continue;
    float gs = 0.0f, gw = 0.0f;
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const bool take = r.depth[j][c + i] > 0.0f;
        const float w = kTap[i] * kTap[j];
        gs = gs + (take ? w * r.intensity[j][c + i] : 0.0f);
        gw = gw + (take ? w : 0.0f);
      }
    intensity_out[x] = depth > 0.0f ? (gw > 0.0f ? gs / gw : 0.0f) : 0.0f;
  }
}

}  // namespace ef::kernels
