// What the SIMD variants of crf_rows share, written once: slice, splat and blur of 16-float rows
// (contracts in kernels/crf_rows.h) over a small vector-ops class that each ISA file defines with its
// intrinsics. A row is kCrfRowFloats / V::kWidth registers, handled one register after another with
// the reference's operations in the reference's order, so every lane gives crf_rows_ref's bits.
// Internal linkage (anonymous namespace): each ISA file compiles its own copy with its own flags (the
// rule in kernels/variants.h).
//
// The vector-ops class V is the ISA's kernels/f32_ops_<isa>.h type; of it the loops use F (a register
// of kWidth floats), kWidth, zero(), set1(float), load(const float*), store(float*, F), add(F, F),
// mul(F, F) - a separate multiply and add, never a fused one (the kernels build with
// -ffp-contract=off, and the intrinsics are the unfused ones) - and prefetch(const float*) (a read
// hint for the row's cache line).
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/crf_rows_variants.h"

namespace ef::kernels {
namespace {

// Prefetch distance (points): rows are scattered over a lattice larger than L2, but points come in
// spatial order, so the rows a few points ahead are the ones to fetch.
constexpr std::size_t kCrfPrefetch = 4;

// The 7 rows the point whose vertex ids start at v will read or write.
template <class V>
inline void crf_prefetch_rows(const float* rows, const uint32_t* v) {
  for (int k = 0; k < kCrfSimplex; ++k) V::prefetch(rows + std::size_t(v[k]) * kCrfRowFloats);
}

template <class V>
void crf_slice(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, float* out) {
  constexpr int kRegs = kCrfRowFloats / V::kWidth;  // registers per row
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kCrfPrefetch < points) crf_prefetch_rows<V>(rows, vertices + (p + kCrfPrefetch) * kCrfSimplex);
    const uint32_t* v = vertices + p * kCrfSimplex;
    const uint16_t* w = weights + p * kCrfSimplex;
    typename V::F acc[kRegs];
    for (int j = 0; j < kRegs; ++j) acc[j] = V::zero();
    for (int k = 0; k < kCrfSimplex; ++k) {
      const float* r = rows + std::size_t(v[k]) * kCrfRowFloats;
      const typename V::F wk = V::set1(float(w[k]));
      for (int j = 0; j < kRegs; ++j) acc[j] = V::add(acc[j], V::mul(wk, V::load(r + j * V::kWidth)));
    }
    for (int j = 0; j < kRegs; ++j) V::store(out + p * kCrfRowFloats + j * V::kWidth, acc[j]);
  }
}

template <class V>
void crf_splat(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, const float* in) {
  constexpr int kRegs = kCrfRowFloats / V::kWidth;
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kCrfPrefetch < points) crf_prefetch_rows<V>(rows, vertices + (p + kCrfPrefetch) * kCrfSimplex);
    const uint32_t* v = vertices + p * kCrfSimplex;
    const uint16_t* w = weights + p * kCrfSimplex;
    typename V::F x[kRegs];
    for (int j = 0; j < kRegs; ++j) x[j] = V::load(in + p * kCrfRowFloats + j * V::kWidth);
    // Vertex after vertex, each row read after the previous vertex's store: a row named twice
    // accumulates in the reference's order.
    for (int k = 0; k < kCrfSimplex; ++k) {
      float* r = rows + std::size_t(v[k]) * kCrfRowFloats;
      const typename V::F wk = V::set1(float(w[k]));
      for (int j = 0; j < kRegs; ++j) {
        float* rj = r + j * V::kWidth;
        V::store(rj, V::add(V::load(rj), V::mul(wk, x[j])));
      }
    }
  }
}

template <class V>
void crf_blur(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end) {
  const typename V::F half = V::set1(0.5f), quarter = V::set1(0.25f);
  for (std::size_t v = begin; v < end; ++v) {
    const float* m = in + std::size_t(neighbours[2 * v]) * kCrfRowFloats;
    const float* p = in + std::size_t(neighbours[2 * v + 1]) * kCrfRowFloats;
    const float* c = in + v * kCrfRowFloats;
    for (int h = 0; h < kCrfRowFloats; h += V::kWidth)
      V::store(out + v * kCrfRowFloats + h,
               V::add(V::mul(half, V::load(c + h)), V::mul(quarter, V::add(V::load(m + h), V::load(p + h)))));
  }
}

// The variant's row of kCrfRowsVariants.
template <class V>
constexpr CrfRowsKernel crf_rows_kernel() {
  return {&crf_slice<V>, &crf_splat<V>, &crf_blur<V>};
}

}  // namespace
}  // namespace ef::kernels
