// Internal to the SIMD variants of normal_row: the per-pixel maths of kernels/normal_row.h written
// once over a small vector-ops type that each ISA file defines with its intrinsics, kWidth pixels of
// the row at a time. The vertex and normal maps hold x, y, z per pixel, so every load de-interleaves
// three components and the store interleaves them again. Internal linkage throughout (anonymous
// namespace): each ISA file compiles its own copy with its own flags (the rule in kernels/variants.h).
// The last step of a row overlaps the one before it (each pixel depends on the inputs only, so the
// overlapped pixels are written twice with the same bits); a row shorter than one step goes to
// normal_row_ref.
//
// A vector-ops type V provides (F: kWidth floats, M: a lane mask):
//   set1(float)  load3(p, F& x, F& y, F& z): p[3k], p[3k + 1], p[3k + 2], k = 0 .. kWidth - 1
//   store3(p, x, y, z): the inverse  add sub mul div sqrt abs  gt le (ordered, as C++'s > <=)
//   land  select(M, a, b): a where the mask is set, else b
// Every float operation is the single IEEE operation of the reference in the same order, so each lane
// is bit-identical to normal_row_ref.
#pragma once

#include "kernels/normal_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

template <class V>
inline void normal_row_step(const NormalRow& r, int x, float* normal) {
  using F = typename V::F;
  using M = typename V::M;
  const F zero = V::set1(0.0f), one = V::set1(1.0f), minus_one = V::set1(-1.0f);
  F cx, cy, cz, lx, ly, lz, rx, ry, rz, ux, uy, uz, dx, dy, dz;
  V::load3(r.vertex[1] + 3 * x, cx, cy, cz);
  V::load3(r.vertex[1] + 3 * x - 3, lx, ly, lz);
  V::load3(r.vertex[1] + 3 * x + 3, rx, ry, rz);
  V::load3(r.vertex[0] + 3 * x, ux, uy, uz);
  V::load3(r.vertex[2] + 3 * x, dx, dy, dz);
  const F mx = V::mul(cz, V::set1(r.step_x)), my = V::mul(cz, V::set1(r.step_y));
  M ok = V::gt(cz, zero);
  ok = V::land(ok, V::le(V::abs(V::sub(lz, cz)), mx));
  ok = V::land(ok, V::le(V::abs(V::sub(rz, cz)), mx));
  ok = V::land(ok, V::le(V::abs(V::sub(uz, cz)), my));
  ok = V::land(ok, V::le(V::abs(V::sub(dz, cz)), my));
  ok = V::land(ok, V::land(V::land(V::gt(lz, zero), V::gt(rz, zero)), V::land(V::gt(uz, zero), V::gt(dz, zero))));
  const F ax = V::sub(rx, lx), ay = V::sub(ry, ly), az = V::sub(rz, lz);
  const F bx = V::sub(dx, ux), by = V::sub(dy, uy), bz = V::sub(dz, uz);
  const F px = V::sub(V::mul(by, az), V::mul(bz, ay));
  const F py = V::sub(V::mul(bz, ax), V::mul(bx, az));
  const F pz = V::sub(V::mul(bx, ay), V::mul(by, ax));
  const F len2 = V::add(V::mul(px, px), V::add(V::mul(py, py), V::mul(pz, pz)));
  ok = V::land(ok, V::gt(len2, zero));
  // inf or NaN where len2 is 0: such lanes are not ok.
  F nx, ny, nz;
  if (r.divide) {
    const F root = V::sqrt(len2);
    nx = V::div(px, root);
    ny = V::div(py, root);
    nz = V::div(pz, root);
  } else {
    const F s = V::div(one, V::sqrt(len2));
    nx = V::mul(px, s);
    ny = V::mul(py, s);
    nz = V::mul(pz, s);
  }
  const F dot = V::add(V::mul(nx, cx), V::add(V::mul(ny, cy), V::mul(nz, cz)));
  const F sign = V::select(V::gt(dot, zero), minus_one, one);
  V::store3(normal + 3 * x, V::select(ok, V::mul(sign, nx), zero), V::select(ok, V::mul(sign, ny), zero),
            V::select(ok, V::mul(sign, nz), zero));
}

template <class V>
void normal_row_simd(const NormalRow& r, int x_begin, int x_end, float* normal) {
  constexpr int kW = V::kWidth;
  if (x_end - x_begin < kW) {
    normal_row_ref(r, x_begin, x_end, normal);
    return;
  }
  for (int x = x_begin;; x += kW) {
    if (x + kW > x_end) x = x_end - kW;  // the last step overlaps the one before
    normal_row_step<V>(r, x, normal);
    if (x + kW == x_end) break;
  }
}

}  // namespace
}  // namespace ef::kernels
