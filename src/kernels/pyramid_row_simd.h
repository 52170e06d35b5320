// Internal to the SIMD variants of pyramid_row: the per-pixel maths of kernels/pyramid_row.h written
// once over a small vector-ops type that each ISA file defines with its intrinsics, kWidth coarse
// pixels of the row at a time. Coarse pixel x reads finer columns 2x - 1 .. 2x + 2, so each finer row
// is two de-interleaving loads: columns 2x - 1 + 2k and 2x + 2k (the window's columns 0 and 1 for
// lane k), then 2x + 1 + 2k and 2x + 2 + 2k (columns 2 and 3). Internal linkage throughout (anonymous
// namespace): each ISA file compiles its own copy with its own flags (the rule in kernels/variants.h).
// The last step of a row overlaps the one before it (each coarse pixel depends on the inputs only,
// so the overlapped pixels are written twice with the same bits); a row shorter than one step goes
// to pyramid_row_ref.
//
// A vector-ops type V provides (F: kWidth floats, M: a lane mask):
//   set1(float) store(p, F)  load2(p, F& even, F& odd): p[2k] and p[2k + 1], k = 0 .. kWidth - 1
//   add sub mul div abs  gt le lt ne (C++'s > <= < !=: ordered, but ne true on NaN)  land
//   select(M, a, b): a where the mask is set, else b
// Every float operation is the single IEEE operation of the reference in the same order, so each lane
// is bit-identical to pyramid_row_ref.
#pragma once

#include "kernels/pyramid_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

template <class V>
inline void pyramid_row_step(const PyramidRow& r, int x, bool with_intensity, float* depth_out, float* intensity_out) {
  using F = typename V::F;
  using M = typename V::M;
  constexpr float kTap[4] = {1.0f, 3.0f, 3.0f, 1.0f};
  const F zero = V::set1(0.0f), one = V::set1(1.0f), inf = V::set1(__builtin_inff());
  const F thr = V::set1(r.threshold_m);
  F d[4][4];  // [row j][column i] of each lane's window
  for (int j = 0; j < 4; ++j) {
    V::load2(r.depth[j] + 2 * x - 1, d[j][0], d[j][1]);
    V::load2(r.depth[j] + 2 * x + 1, d[j][2], d[j][3]);
  }
  const F block[4] = {d[1][1], d[1][2], d[2][1], d[2][2]};
  F nearest = inf;
  for (const F& b : block) {
    const F v = V::select(V::gt(b, zero), b, inf);
    nearest = V::select(V::lt(v, nearest), v, nearest);
  }
  const F limit = V::add(nearest, thr);
  F rs = zero, rn = zero;
  for (const F& b : block) {
    const M near_surface = V::land(V::gt(b, zero), V::le(b, limit));
    rs = V::add(rs, V::select(near_surface, b, zero));
    rn = V::add(rn, V::select(near_surface, one, zero));
  }
  const F ref = V::div(rs, rn);
  F s = zero, wt = zero;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      const F w = V::set1(kTap[i] * kTap[j]);
      const M take = V::land(V::gt(d[j][i], zero), V::le(V::abs(V::sub(d[j][i], ref)), thr));
      s = V::add(s, V::select(take, V::mul(w, d[j][i]), zero));
      wt = V::add(wt, V::select(take, w, zero));
    }
  const F depth = V::select(V::ne(nearest, inf), V::select(V::gt(wt, zero), V::div(s, wt), ref), zero);
  V::store(depth_out + x, depth);
  if (!with_intensity) return;
  F gs = zero, gw = zero;
  for (int j = 0; j < 4; ++j) {
    F g[4];
    V::load2(r.intensity[j] + 2 * x - 1, g[0], g[1]);
    V::load2(r.intensity[j] + 2 * x + 1, g[2], g[3]);
    for (int i = 0; i < 4; ++i) {
      const F w = V::set1(kTap[i] * kTap[j]);
      const M take = V::gt(d[j][i], zero);
      gs = V::add(gs, V::select(take, V::mul(w, g[i]), zero));
      gw = V::add(gw, V::select(take, w, zero));
    }
  }
  const F intensity = V::select(V::gt(depth, zero), V::select(V::gt(gw, zero), V::div(gs, gw), zero), zero);
  V::store(intensity_out + x, intensity);
}

template <class V>
void pyramid_row_simd(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  constexpr int kW = V::kWidth;
  if (x_end - x_begin < kW) {
    pyramid_row_ref(r, x_begin, x_end, depth_out, intensity_out);
    return;
  }
  const bool with_intensity = r.intensity[0] != nullptr;
  for (int x = x_begin;; x += kW) {
    if (x + kW > x_end) x = x_end - kW;  // the last step overlaps the one before
    pyramid_row_step<V>(r, x, with_intensity, depth_out, intensity_out);
    if (x + kW == x_end) break;
  }
}

}  // namespace
}  // namespace ef::kernels
