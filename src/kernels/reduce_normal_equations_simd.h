// Internal to the SIMD variants of reduce_normal_equations: the loop structure they share, written
// once over a small vector-ops type that each ISA file defines with its intrinsics. Everything here
// has internal linkage (anonymous namespace), so each ISA file compiles its own copy with its own
// flags (see the rule in kernels/variants.h); only baseline functions (ne_*) are called across.
//
// A vector-ops type V provides:
//   using F;  static constexpr int kWidth (4 or 8 lanes);  zero(); load(const float*) (unaligned);
//   mul(a, b); add(a, b) (these from the ISA's kernels/f32_ops_<isa>.h type);  add_to_totals(double* t,
//   F v): t[j] += double(v[j]) for j < kWidth (each ISA file's own).
// A register holds lanes [lane0, lane0 + kWidth) of the 8 lanes of the specification, so 4-wide
// ISAs run every pass twice (lane0 = 0 and 4) and 8-wide ones once; either way each lane sees exactly
// the additions of the scalar reference, in the same order.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/reduce_normal_equations_variants.h"

// No contraction into FMA from here to the end of the including ISA file: the templates below and the
// includer's vector-ops type are compiled with separate multiply and add, as the reference.
#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

constexpr int ne_row_len(int p) { return p < 0 ? 0 : 7 - p; }

// One pass accumulates the outputs of up to four rows P0..P3 (-1 = unused) of the upper triangle,
// e.g. row 1 is (1,1) .. (1,6). Passes exist so that the accumulators of a pass fit in registers
// (16 on SSE/AVX2, 32 on AVX-512/NEON); how outputs are split into passes does not change any sum.
template <class V, int P0, int P1 = -1, int P2 = -1, int P3 = -1>
struct NePass {
  using F = typename V::F;
  static constexpr int kRows[4] = {P0, P1, P2, P3};
  static constexpr int kFirst[4] = {0, ne_row_len(P0), ne_row_len(P0) + ne_row_len(P1),
                                    ne_row_len(P0) + ne_row_len(P1) + ne_row_len(P2)};
  static constexpr int kCount = kFirst[3] + ne_row_len(P3);

  // One group: g points at component 0 of the group's first lane; component k is at g[k * stride].
  static inline void group(const float* g, std::size_t stride, F* acc) {
    const F w = V::load(g + 7 * stride);
    F wa[4];
#pragma GCC unroll 4
    for (int j = 0; j < 4; ++j) wa[j] = kRows[j] >= 0 ? V::mul(w, V::load(g + kRows[j] * stride)) : w;
#pragma GCC unroll 7
    for (int q = 0; q < 7; ++q) {
      const F x = V::load(g + q * stride);
#pragma GCC unroll 4
      for (int j = 0; j < 4; ++j) {
        if (kRows[j] >= 0 && kRows[j] <= q) {
          F& a = acc[kFirst[j] + q - kRows[j]];
          a = V::add(a, V::mul(wa[j], x));  // (w * a_p) * a_q, then the add: as the reference
        }
      }
    }
  }

  // Lanes [lane0, lane0 + kWidth) of the whole groups in [begin, end_full), then of the padded tail
  // tile (8-row stride) if any; the block's float sums are then added to the double totals.
  static void run(const float* rows, std::size_t stride, std::size_t begin, std::size_t end_full, const float* tile,
                  int lane0, double* totals) {
    F acc[kCount];
#pragma GCC unroll 16
    for (int c = 0; c < kCount; ++c) acc[c] = V::zero();
    for (std::size_t i = begin; i < end_full; i += kNeLanes) group(rows + i + lane0, stride, acc);
    if (tile != nullptr) group(tile + lane0, kNeLanes, acc);
#pragma GCC unroll 4
    for (int j = 0; j < 4; ++j) {
      if (kRows[j] < 0) continue;
#pragma GCC unroll 7
      for (int q = kRows[j]; q < 7; ++q)
        V::add_to_totals(totals + ne_index(kRows[j], q) * kNeLanes + lane0, acc[kFirst[j] + q - kRows[j]]);
    }
  }
};

// The whole reduction: blocks of kNeBlockRows rows, every pass over every lane range of each block.
// The passes together must cover rows 0..6 of the triangle exactly once.
template <class V, class... Passes>
void ne_reduce_simd(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  static_assert((Passes::kCount + ...) == kNeOutputs, "passes must cover the 28 outputs");
  NeLaneTotals totals = {};
  for (std::size_t block = 0; block < n; block += kNeBlockRows) {
    const std::size_t end = n - block < kNeBlockRows ? n : block + kNeBlockRows;
    const std::size_t end_full = block + (end - block) / kNeLanes * kNeLanes;
    float tile[kNeComponents * kNeLanes];
    const float* t = nullptr;
    if (end_full < end) {
      ne_tail_tile(rows, stride, end_full, end - end_full, tile);
      t = tile;
    }
    for (int lane0 = 0; lane0 < kNeLanes; lane0 += V::kWidth)
      (Passes::run(rows, stride, block, end_full, t, lane0, totals), ...);
  }
  ne_finish(totals, n ? ne_count_inliers(rows + 7 * stride, n) : 0, out);
}

}  // namespace
}  // namespace ef::kernels
