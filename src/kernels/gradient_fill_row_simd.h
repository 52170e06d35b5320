// Internal to the SIMD variants of gradient_fill_row: the per-pixel maths of
// kernels/gradient_fill_row.h written once over a small vector-ops type that each ISA file defines
// with its intrinsics, kWidth consecutive pixels at a time (their neighbours are consecutive too:
// plain loads). Internal linkage throughout (anonymous namespace): each ISA file compiles its own
// copy with its own flags (the rule in kernels/variants.h). The last step of a row overlaps the one
// before it (each pixel depends on the inputs only, so the overlapped pixels are written twice with
// the same bits); a row shorter than one step goes to gradient_fill_row_ref.
//
// A vector-ops type V provides (F: kWidth floats, M: a lane mask):
//   set1(float) load(p) store(p, F)  add sub mul div  gt (ordered, as C++'s >)
//   select(M, a, b): a where the mask is set, else b
// Every float operation is the single IEEE operation of the reference in the same order, so each lane
// is bit-identical to gradient_fill_row_ref.
#pragma once

#include "kernels/gradient_fill_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

template <class V>
inline void gradient_fill_row_step(const GradientFillRow& r, int x, float* grad_x, float* grad_y, float* filled) {
  using F = typename V::F;
  using M = typename V::M;
  const F zero = V::set1(0.0f), one = V::set1(1.0f), two = V::set1(2.0f), eighth = V::set1(0.125f);
  const F c = V::load(r.intensity[1] + x);
  M has[3][3];
  F g[3][3];
  for (int row = 0; row < 3; ++row)
    for (int k = 0; k < 3; ++k) {
      has[row][k] = V::gt(V::load(r.depth[row] + x + k - 1), zero);
      g[row][k] = V::load(r.intensity[row] + x + k - 1);
    }
  const auto tap = [&](int row, int k) { return V::select(has[row][k], g[row][k], c); };
  const auto s = [&](int row, int k) { return V::select(has[row][k], g[row][k], zero); };
  const auto m = [&](int row, int k) { return V::select(has[row][k], one, zero); };
  const F ul = tap(0, 0), u = tap(0, 1), ur = tap(0, 2), le = tap(1, 0), ri = tap(1, 2);
  const F dl = tap(2, 0), d = tap(2, 1), dr = tap(2, 2);
  const F gx = V::mul(V::sub(V::add(V::add(ur, V::mul(two, ri)), dr), V::add(V::add(ul, V::mul(two, le)), dl)), eighth);
  const F gy = V::mul(V::sub(V::add(V::add(dl, V::mul(two, d)), dr), V::add(V::add(ul, V::mul(two, u)), ur)), eighth);
  const M own = has[1][1];
  V::store(grad_x + x, V::select(own, gx, zero));
  V::store(grad_y + x, V::select(own, gy, zero));
  const F sum = V::add(V::add(V::add(V::add(s(0, 0), s(0, 1)), s(0, 2)), V::add(s(1, 0), s(1, 2))),
                       V::add(V::add(s(2, 0), s(2, 1)), s(2, 2)));
  F n = m(0, 0);
  n = V::add(n, m(0, 1));
  n = V::add(n, m(0, 2));
  n = V::add(n, m(1, 0));
  n = V::add(n, m(1, 2));
  n = V::add(n, m(2, 0));
  n = V::add(n, m(2, 1));
  n = V::add(n, m(2, 2));
  V::store(filled + x, V::select(own, c, V::div(sum, V::add(n, V::set1(1e-30f)))));
}

template <class V>
void gradient_fill_row_simd(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                            float* filled) {
  constexpr int kW = V::kWidth;
  if (x_end - x_begin < kW) {
    gradient_fill_row_ref(r, x_begin, x_end, grad_x, grad_y, filled);
    return;
  }
  for (int x = x_begin;; x += kW) {
    if (x + kW > x_end) x = x_end - kW;  // the last step overlaps the one before
    gradient_fill_row_step<V>(r, x, grad_x, grad_y, filled);
    if (x + kW == x_end) break;
  }
}

}  // namespace
}  // namespace ef::kernels
