// Internal to the SIMD variants of bilateral_row: the per-pixel maths of kernels/bilateral_row.h
// written once over a small vector-ops type that each ISA file defines with its intrinsics, kWidth
// consecutive output pixels at a time (their neighbours are consecutive too: plain loads). Internal
// linkage throughout (anonymous namespace): each ISA file compiles its own copy with its own flags
// (the rule in kernels/variants.h); the tail of a row goes to bilateral_row_ref.
//
// A vector-ops type V provides (F: kWidth floats, M: a lane mask):
//   set1(float) load(p) store(p, F) add sub mul div  gt(F, F) (ordered, as C++'s >)
//   keep(M, F): the lane where m, else +0
// Every float operation is the single IEEE operation of the reference in the same order, so each lane
// is bit-identical to bilateral_row_ref.
#pragma once

#include "kernels/bilateral_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

template <class V>
void bilateral_row_simd(const BilateralRow& b, int width, float* out) {
  using F = typename V::F;
  constexpr int kW = V::kWidth;
  const int r = b.radius, n = 2 * r + 1;
  const F one = V::set1(1.0f), k8 = V::set1(b.k8), zero = V::set1(0.0f);
  int x = 0;
  for (; x + kW <= width; x += kW) {
    const F c = V::load(b.rows[r] + x + r);
    F sw = zero, swd = zero;
    for (int dy = 0; dy < n; ++dy) {
      const float* row = b.rows[dy] + x;
      for (int dx = 0; dx < n; ++dx) {
        const F nb = V::load(row + dx);
        const F d = V::sub(nb, c);
        const F u = V::add(one, V::mul(V::mul(d, d), k8));
        const F u2 = V::mul(u, u);
        const F u4 = V::mul(u2, u2);
        const F w = V::mul(V::set1(b.spatial[dy * n + dx]), V::div(one, V::mul(u4, u4)));
        sw = V::add(sw, w);
        swd = V::add(swd, V::mul(w, nb));
      }
    }
    V::store(out + x, V::keep(V::gt(V::load(b.raw + x), zero), V::div(swd, sw)));
  }
  if (x < width) {
    // The tail as the reference does it, on the row pointers moved to the tail's first pixel.
    const float* rows[17];
    for (int k = 0; k < n; ++k) rows[k] = b.rows[k] + x;
    BilateralRow tail = b;
    tail.rows = rows;
    tail.raw = b.raw + x;
    bilateral_row_ref(tail, width - x, out + x);
  }
}

}  // namespace
}  // namespace ef::kernels
