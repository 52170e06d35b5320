// Row kernels of the dense CRF's permutohedral-lattice filter (semantic/permutohedral_lattice.h,
// semantic/dense_crf.h): every value vector is one row of 16 floats (a 64-byte cache line), and the
// mean-field iterations only move such rows:
//   slice  out_p = sum over k = 0..6 of w_pk * rows[v_pk]      (a point's 7 simplex vertices)
//   splat  rows[v_pk] += w_pk * in_p                            (k = 0..6, point after point)
//   blur   out_v = 0.5 * in_v + 0.25 * (in_minus(v) + in_plus(v))   (one lattice direction)
// Weights are uint16 (65535 = barycentric 1, converted to float exactly). Each element's maths is a
// fixed sequence of IEEE float multiplies and adds, written out in crf_rows_ref.cpp; every variant
// performs the same operations in the same order per element (no fused multiply-add: kernels build
// with -ffp-contract=off), so all variants give the reference's bits.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::kernels {

inline constexpr int kCrfRowFloats = 16;  // floats per row
inline constexpr int kCrfSimplex = 7;     // vertices per point (d + 1 for the 6-d lattice)

// For each point p < points: out[16p + c] = (((0 + w_p0 r_p0[c]) + w_p1 r_p1[c]) + ...) + w_p6 r_p6[c]
// with r_pk = rows + 16 * vertices[7p + k] and w_pk = float(weights[7p + k]). out must not alias rows.
void crf_slice_rows(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points,
                    float* out);

// For each point p < points in order, for k = 0..6 in order:
//   rows[16 v + c] = rows[16 v + c] + float(weights[7p + k]) * in[16p + c],  v = vertices[7p + k]
// (a vertex named twice, by one point or by several, accumulates in that order). in must not alias rows.
void crf_splat_rows(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points,
                    const float* in);

// For each vertex v in [begin, end): out[16v + c] = 0.5 * in[16v + c] + 0.25 * (in[16 m + c] + in[16 p + c])
// with m = neighbours[2v], p = neighbours[2v + 1] (the two neighbours along one direction; a missing
// one names an all-zero row). out must not alias in.
void crf_blur_rows(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end);

// Name of the variant the three functions above dispatch to on this CPU (e.g. "crf_rows__avx2").
const char* crf_rows_selected();

}  // namespace ef::kernels
