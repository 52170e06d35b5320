// Scalar reference of reduce_normal_equations: the specification of the summation order that every
// SIMD variant reproduces bit for bit (see kernels/normal_equations.h).
//   lane l = i mod 8; block = i / 512.
//   Within a block, per output o = (p, q) and lane l, a float sum starting at +0:
//     s[o][l] = s[o][l] + ((w_i * a_i[p]) * a_i[q])      (each * and + rounded to float)
//   At the end of each block: T[o][l] = T[o][l] + double(s[o][l])  (double, starting at +0).
//   Finally A[o] = ((T0 + T1) + (T2 + T3)) + ((T4 + T5) + (T6 + T7)).
#include "kernels/reduce_normal_equations_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void reduce_normal_equations_ref(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  NeLaneTotals totals = {};
  for (std::size_t block = 0; block < n; block += kNeBlockRows) {
    const std::size_t end = n - block < kNeBlockRows ? n : block + kNeBlockRows;
    float s[kNeOutputs][kNeLanes] = {};
    for (std::size_t i = block; i < end; ++i) {
      const std::size_t l = i % kNeLanes;
      float a[7];
      for (int k = 0; k < 7; ++k) a[k] = rows[k * stride + i];
      const float w = rows[7 * stride + i];
      int o = 0;
      for (int p = 0; p < 7; ++p) {
        const float wa = w * a[p];
        for (int q = p; q < 7; ++q, ++o) s[o][l] = s[o][l] + wa * a[q];
      }
    }
    for (int o = 0; o < kNeOutputs; ++o)
      for (int l = 0; l < kNeLanes; ++l) totals[o * kNeLanes + l] += static_cast<double>(s[o][l]);
  }
  ne_finish(totals, n ? ne_count_inliers(rows + 7 * stride, n) : 0, out);
}

}  // namespace ef::kernels
