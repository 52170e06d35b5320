// One interior row of a coarse pyramid level, the rule of slam/depth_pyramid.h: each coarse pixel's
// depth from the 4x4 window of finer pixels around its 2x2 block, and optionally its intensity from
// the finer intensities under the same window (the model prediction's pyramid, where only finer
// pixels with a prediction count).
//
// Coarse pixel x reads finer columns 2x - 1 .. 2x + 2 of the four finer rows 2y - 1 .. 2y + 2 (row j,
// column i of the window: depth[j][2x - 1 + i]); its block is rows j = 1, 2 and columns i = 1, 2.
// With w(i, j) = t[i] t[j], t = {1, 3, 3, 1}, thr = threshold_m, inf = +infinity:
//   nearest = inf;  for the block's four depths d in the order (j, i) = (1,1) (1,2) (2,1) (2,2):
//                     nearest = (v < nearest) ? v : nearest,  v = d > 0 ? d : inf
//   rs = rn = 0;    for the same four: near = d > 0 && d <= nearest + thr;
//                     rs = rs + (near ? d : 0);  rn = rn + (near ? 1 : 0)
//   ref = rs / rn
//   s = wt = 0;     for j = 0..3, i = 0..3 (j outer): take = d > 0 && |d - ref| <= thr;
//                     s = s + (take ? w d : 0);  wt = wt + (take ? w : 0)
//   depth_out[x] = nearest != inf ? (wt > 0 ? s / wt : ref) : 0
// and with intensity rows g:
//   gs = gw = 0;    for j, i as above: take = d > 0;  gs = gs + (take ? w g : 0);  gw = gw + (take ? w : 0)
//   intensity_out[x] = depth_out[x] > 0 ? (gw > 0 ? gs / gw : 0) : 0
// Every operation is one IEEE float operation in the order written (kernel files build with
// contraction off), so every variant writes the same bits as the scalar reference. Each coarse pixel
// depends on the inputs only, so a variant may compute a pixel twice (its last step overlaps).
#pragma once

namespace ef::kernels {

struct PyramidRow {
  const float* depth[4] = {nullptr, nullptr, nullptr, nullptr};      // finer rows 2y - 1 .. 2y + 2, metres (0 = none), at column 0
  const float* intensity[4] = {nullptr, nullptr, nullptr, nullptr};  // the same rows' intensities, or all null: depth only
  float threshold_m = 0.0f;                                          // the depth rule's thr, metres
};

// Writes depth_out[x] (and intensity_out[x] when the intensity rows are given) for coarse pixels x in
// [x_begin, x_end); needs 1 <= x_begin and 2 x_end <= finer width - 1 (every column read lies in the
// rows). Dispatched to the best variant for this CPU (platform/cpu_features; EF_ISA caps it). No heap
// allocation.
void pyramid_row(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out);

}  // namespace ef::kernels
