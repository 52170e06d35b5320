// Gauss-Newton normal equations: the reduction at the heart of ICP / photometric tracking.
//
// Each residual row i has a Jacobian J_i (1x6, with respect to a twist (v, w) of SE3), a residual r_i
// and a weight w_i >= 0. The tracker needs A = sum_i w_i a_i a_i^T with a_i = (J_i, r_i) (7 values):
// its 6x6 top-left block is J^T W J, its last column J^T W r, its corner sum w r^2. A is symmetric,
// so only the upper triangle (28 values) is produced.
//
// Input layout: structure of arrays, one float stream per component, so a residual loop that works
// on 4 or 8 pixels at a time writes whole vectors and a scalar loop writes 8 plain stores:
//   rows[k * stride + i]   component k of row i; k = 0..5 J, 6 r, 7 w   (stride >= n)
// Every value must be finite. A row that should not count (an invalid pixel, a rejected outlier) is
// written with w = 0 (and finite J, r): it then adds exactly zero.
//
// Exactness: every variant (scalar, SSE4.1, AVX2, AVX-512, NEON) returns bit-identical doubles, on
// x86-64 and AArch64 alike. The summation order is part of the contract (see
// reduce_normal_equations_ref.cpp): rows go to 8 lanes (lane = i mod 8); within each block of 512 rows
// each lane sums (w * a_p) * a_q in float, in row order, with a separate multiply and add (no fused
// multiply-add); at the end of each block the lane sums are added into double lane totals; the 8
// double lanes are combined in one fixed tree at the end.
//
// Precision: each float lane sum covers at most 64 rows before it is flushed to double, so the error
// is that of float products plus at most 64 float additions per value. Against a double evaluation of
// the same float inputs on 76,800 realistic point-to-plane rows (one 320x240 frame), the worst error
// over the 28 outputs is 4.3e-9 of sum |term| (tested bound 1e-6), and 1.8e-7 relative to the value
// itself for outputs that do not cancel (tests/kernels/test_normal_equations.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::kernels {

inline constexpr int kNeComponents = 8;           // J0..J5, r, w
inline constexpr int kNeOutputs = 28;             // upper triangle of the 7x7 matrix A
inline constexpr int kNeLanes = 8;                // partial sums per output (lane = row mod 8)
inline constexpr std::size_t kNeBlockRows = 512;  // rows per float block before the double flush

// Position of A(p, q), p <= q <= 6, in NormalEquations::upper: row-major upper triangle.
constexpr int ne_index(int p, int q) { return 7 * p - p * (p - 1) / 2 + (q - p); }

struct NormalEquations {
  // Upper triangle of A = sum w a a^T, a = (J0..J5, r): (0,0) (0,1) .. (0,6) (1,1) .. (6,6).
  double upper[kNeOutputs] = {};
  int64_t inliers = 0;  // rows with w > 0

  // (J^T W J)(p, q) for p, q in 0..5 (either order).
  double jtj(int p, int q) const { return p <= q ? upper[ne_index(p, q)] : upper[ne_index(q, p)]; }
  // (J^T W r)(p), p in 0..5.
  double jtr(int p) const { return upper[ne_index(p, 6)]; }
  // sum of w r^2.
  double r2() const { return upper[ne_index(6, 6)]; }
};

// Reduces rows [0, n) (layout above) into `out` (overwritten). Dispatched to the best variant for
// this CPU (platform/cpu_features; EF_ISA caps it). No heap allocation.
void reduce_normal_equations(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out);

}  // namespace ef::kernels
