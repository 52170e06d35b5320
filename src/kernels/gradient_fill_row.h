// One interior row of the model prediction's intensity maps (slam/model_prediction.h): the Sobel
// gradients the tracker's photometric term reads, and the intensity with its holes filled that it
// samples bilinearly. Both read only the pixels that have a prediction (depth > 0), so one pass over
// the same three rows gives both.
//
// Rows: i[0..2] intensity and d[0..2] depth of image rows y - 1, y, y + 1 (each at pixel 0). For
// pixel x, with c = i[1][x] and tap(r, k) = d[r][x + k] > 0 ? i[r][x + k] : c (a neighbour without a
// prediction takes the centre's value, so a hole's border is not an edge):
//   ul = tap(0, -1)  u = tap(0, 0)  ur = tap(0, 1)  le = tap(1, -1)  ri = tap(1, 1)
//   dl = tap(2, -1)  d = tap(2, 0)  dr = tap(2, 1)
//   gx = (((ur + 2 ri) + dr) - ((ul + 2 le) + dl)) * 0.125
//   gy = (((dl + 2 d) + dr) - ((ul + 2 u) + ur)) * 0.125
//   grad_x[x] = d[1][x] > 0 ? gx : 0;  grad_y[x] = d[1][x] > 0 ? gy : 0
// and with s(r, k) = d[r][x + k] > 0 ? i[r][x + k] : 0, m(r, k) = d[r][x + k] > 0 ? 1 : 0 over the
// eight neighbours:
//   sum = (((s(0,-1) + s(0,0)) + s(0,1)) + (s(1,-1) + s(1,1))) + ((s(2,-1) + s(2,0)) + s(2,1))
//   n = m(0,-1) + m(0,0) + m(0,1) + m(1,-1) + m(1,1) + m(2,-1) + m(2,0) + m(2,1)   (left to right)
//   filled[x] = d[1][x] > 0 ? c : sum / (n + 1e-30)     (1e-30 rounds away for n >= 1; 0 for n = 0)
// Every operation is one IEEE float operation in the order written (kernel files build with
// contraction off), so every variant writes the same bits as the scalar reference. Each pixel depends
// on the inputs only, so a variant may compute a pixel twice (its last step overlaps).
#pragma once

namespace ef::kernels {

struct GradientFillRow {
  const float* intensity[3] = {nullptr, nullptr, nullptr};  // rows y - 1, y, y + 1, grey levels
  const float* depth[3] = {nullptr, nullptr, nullptr};      // the same rows' depths, metres (> 0: predicted)
};

// Writes grad_x[x], grad_y[x] and filled[x] for x in [x_begin, x_end); needs 1 <= x_begin and x_end
// <= width - 1 of the rows. The outputs must not overlap the inputs. Dispatched to the best variant
// for this CPU (platform/cpu_features; EF_ISA caps it). No heap allocation.
void gradient_fill_row(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y, float* filled);

}  // namespace ef::kernels
