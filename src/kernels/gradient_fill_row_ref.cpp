// gradient_fill_row, scalar reference (the specification; see kernels/gradient_fill_row.h).
#include "kernels/gradient_fill_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void gradient_fill_row_ref(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                           float* filled) {
  for (int x = x_begin; x < x_end; ++x) {
    const float c = r.intensity[1][x];
    const auto has = [&](int row, int k) { return r.depth[row][x + k] > 0.0f; };
    const auto tap = [&](int row, int k) { return has(row, k) ? r.intensity[row][x + k] : c; };
    const auto s = [&](int row, int k) { return has(row, k) ? r.intensity[row][x + k] : 0.0f; };
    const auto m = [&](int row, int k) { return has(row, k) ? 1.0f : 0.0f; };
    const float ul = tap(0, -1), u = tap(0, 0), ur = tap(0, 1), le = tap(1, -1), ri = tap(1, 1);
    const float dl = tap(2, -1), d = tap(2, 0), dr = tap(2, 1);
    const float gx = (((ur + 2.0f * ri) + dr) - ((ul + 2.0f * le) + dl)) * 0.125f;
    const float gy = (((dl + 2.0f * d) + dr) - ((ul + 2.0f * u) + ur)) * 0.125f;
    const bool own = has(1, 0);
    grad_x[x] = own ? gx : 0.0f;
    grad_y[x] = own ? gy : 0.0f;
    const float sum = (((s(0, -1) + s(0, 0)) + s(0, 1)) + (s(1, -1) + s(1, 1))) + ((s(2, -1) + s(2, 0)) + s(2, 1));
    const float n = m(0, -1) + m(0, 0) + m(0, 1) + m(1, -1) + m(1, 1) + m(2, -1) + m(2, 0) + m(2, 1);
    filled[x] = own ? c : sum / (n + 1e-30f);
  }
}

}  // namespace ef::kernels
