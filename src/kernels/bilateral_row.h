// One row of the depth bilateral filter of slam/preprocess (KinectFusion, Newcombe et al. ISMAR 2011,
// section 3.1): every output pixel the normalised sum of its (2r+1)^2 neighbours, weighted by a
// spatial Gaussian and a range weight of the depth difference.
//
// Input: 2r+1 rows of the padded depth image (metres; invalid pixels and the border hold a huge
// sentinel whose range weight is exactly 0), row k the image row y - r + k, each pointer at padded
// column 0 (image column -r). For output pixel x, with c = rows[r][x + r] and, for dy, dx in 0..2r
// in that order (rows outer), n = rows[dy][x + dx] and ws = spatial[dy * (2r + 1) + dx]:
//   d = n - c;  u = 1 + (d d) k8;  u2 = u u;  u4 = u2 u2;  w = ws (1 / (u4 u4))   (exp(-t) ~ (1 + t/8)^-8)
//   sw = sw + w;  swd = swd + w n                                       (sw = swd = 0 at the start)
//   out[x] = raw[x] > 0 ? swd / sw : 0
// Every operation is one IEEE float operation in the order written (kernel files build with
// contraction off), so every variant writes the same bits as the scalar reference.
#pragma once

namespace ef::kernels {

struct BilateralRow {
  const float* const* rows = nullptr;  // 2r + 1 padded rows (see above)
  const float* spatial = nullptr;      // (2r + 1)^2 spatial weights, row-major (dy, dx)
  const float* raw = nullptr;          // the row's unfiltered depth, metres (> 0 = valid)
  int radius = 0;                      // r, 1..8
  float k8 = 0;                        // range scale / 8: 1 / (16 sigma_depth^2), per m^2
};

// Writes out[x] for x in [0, width). Dispatched to the best variant for this CPU
// (platform/cpu_features; EF_ISA caps it). No heap allocation.
void bilateral_row(const BilateralRow& b, int width, float* out);

}  // namespace ef::kernels
