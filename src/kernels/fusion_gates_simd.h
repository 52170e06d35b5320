// Internal to the SIMD variants of fusion_gates: the per-pixel maths of kernels/fusion_gates.h written
// once over a small vector-ops type that each ISA file defines with its intrinsics, kWidth pixels of
// the row at a time (consecutive pixels read consecutive index pixels, so every load is contiguous).
// Internal linkage throughout (anonymous namespace): each ISA file compiles its own copy with its
// own flags (the rule in kernels/variants.h). The last step of a row overlaps the one before it (a
// pixel's code depends on the inputs only, so the overlapped pixels get the same code twice; the
// scalar tail cost a quarter of the row's time at 320 pixels); a row shorter than one step goes to
// fusion_gates_ref.
//
// A vector-ops type V provides (F: kWidth floats, I: kWidth int32, M: a lane mask):
//   set1(float) load(p) iset1(int) iload(p) istore(p, I) iota(): 0, 1, ..., kWidth - 1
//   load_surfaces(p, x, y, z): the first three floats of each of kWidth 4-float cells at p
//   add sub mul abs ceil  cvt(I) -> F
//   lt gt eq (ordered: false on NaN, as C++'s < > ==)  igt(I, I)
//   land lor lnot (masks)  set_bits(I c, M m, uint32_t bits): c with `bits` or-ed into the lanes of m
// Every float operation is the single IEEE operation of the reference in the same order, so each lane
// is bit-identical to fusion_gates_ref.
#pragma once

#include <cstdint>

#include "kernels/fusion_gates_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

template <class V>
void fusion_gates_simd(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  using F = typename V::F;
  using I = typename V::I;
  using M = typename V::M;
  constexpr int kW = V::kWidth;
  const F free_space = V::set1(p.neg_free_space_factor), cos_gate = V::set1(p.cos_normal_gate);
  const F half = V::set1(0.5f), row_y = V::set1(static_cast<float>(p.y));
  const I none = V::iset1(-1), pool_size = V::iset1(p.pool_size), last_id = V::iset1(p.pool_size - 1);
  if (x_end - x_begin < kW) {
    fusion_gates_ref(p, row, x_begin, x_end, code);
    return;
  }
  for (int x = x_begin;; x += kW) {
    if (x + kW > x_end) x = x_end - kW;  // the last step overlaps the one before
    const F z = V::load(row.z + x), gate = V::load(row.gate + x);
    const F fs = V::mul(free_space, gate);
    const F nwx = V::load(row.nwx + x), nwy = V::load(row.nwy + x), nwz = V::load(row.nwz + x);
    I c = V::iset1(0);
    for (int k = 0; k < 9; ++k) {
      const int r = k / 3, cx = x + k % 3 - 1;
      const I id = V::iload(p.id[r] + cx);
      const M occupied = V::land(V::igt(id, none), V::igt(pool_size, id));
      const F dz = V::sub(V::load(p.depth[r] + cx), z);
      const M violated = V::lt(dz, fs);
      const M depth_ok = V::lnot(V::lor(violated, V::gt(V::abs(dz), gate)));
      F sx, sy, sz;
      V::load_surfaces(p.surface[r] + 4 * cx, sx, sy, sz);
      const F cos_n = V::add(V::add(V::mul(sx, nwx), V::mul(sy, nwy)), V::mul(sz, nwz));
      const M normal_ok = V::lnot(V::lt(cos_n, cos_gate));
      c = V::set_bits(c, occupied, 1u << k);
      c = V::set_bits(c, V::land(occupied, depth_ok), 1u << (kGateDepthShift + k));
      c = V::set_bits(c, V::land(occupied, normal_ok), 1u << (kGateNormalShift + k));
      c = V::set_bits(c, V::igt(id, last_id), kGateInvalid);
      if (k == 4) c = V::set_bits(c, V::land(occupied, violated), kGateOwnViolated);
    }
    const F xs = V::cvt(V::iadd(V::iset1(x), V::iota()));
    const M identity = V::land(V::eq(V::ceil(V::sub(V::load(row.xi + x), half)), xs),
                               V::eq(V::ceil(V::sub(V::load(row.yi + x), half)), row_y));
    c = V::set_bits(c, identity, kGateIdentity);
    V::istore(code + x, c);
    if (x + kW == x_end) break;
  }
}

}  // namespace
}  // namespace ef::kernels
