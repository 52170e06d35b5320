// bilateral_row, scalar reference (the specification; see kernels/bilateral_row.h).
#include "kernels/bilateral_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void bilateral_row_ref(const BilateralRow& b, int width, float* out) {
  const int r = b.radius, n = 2 * r + 1;
  for (int x = 0; x < width; ++x) {
    const float c = b.rows[r][x + r];
    float sw = 0.0f, swd = 0.0f;
    for (int dy = 0; dy < n; ++dy) {
      const float* row = b.rows[dy] + x;
      for (int dx = 0; dx < n; ++dx) {
        const float nb = row[dx];
        const float d = nb - c;
        const float u = 1.0f + d * d * b.k8;
        const float u2 = u * u;
        const float u4 = u2 * u2;
        const float w = b.spatial[dy * n + dx] * (1.0f / (u4 * u4));
        sw = sw + w;
        swd = swd + w * nb;
      }
    }
    out[x] = b.raw[x] > 0.0f ? swd / sw : 0.0f;
  }
}

}  // namespace ef::kernels
