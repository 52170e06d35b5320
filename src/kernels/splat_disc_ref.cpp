// splat_disc, scalar reference (the specification; see kernels/splat_disc.h). Branch-free per pixel:
// whether a pixel is covered is data-dependent and unpredictable, so the stores are selects.
#include <cstddef>

#include "kernels/splat_disc_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void splat_disc_ref(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner,
                    int width) {
  const float nx = d.nx, ny = d.ny, nz = d.nz, xc = d.xc, yc = d.yc, zc = d.zc, np = d.np;
  const float r2 = d.r2, tie = d.tie, near = d.near;
  const int32_t sid = d.id;
  for (int y = d.y0; y <= d.y1; ++y) {
    const float dy = ray_y[y];
    const float row_term = ny * dy + nz;
    float* zrow = key + static_cast<std::size_t>(y) * width;
    int32_t* idrow = winner + static_cast<std::size_t>(y) * width;
    for (int x = d.x0; x <= d.x1; ++x) {
      const float dx = ray_x[x];
      const float denom = nx * dx + row_term;
      const float z = np / (-1e-12f < denom ? -1e-12f : denom);  // std::min(denom, -1e-12f)
      const float ex = dx * z - xc, ey = dy * z - yc, ez = z - zc;
      const float e2 = ex * ex + ey * ey + ez * ez;
      const float k = z + z * tie * e2;
      const bool wins = (denom < 0.0f) & (e2 <= r2) & (z >= near) & (k < zrow[x]);
      zrow[x] = wins ? k : zrow[x];
      idrow[x] = wins ? sid : idrow[x];
    }
  }
}

}  // namespace ef::kernels
