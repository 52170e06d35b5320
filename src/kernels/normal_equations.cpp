// Run-time dispatch of reduce_normal_equations, and the steps every variant shares (compiled for
// the baseline ISA, so the summation order they fix is the same code everywhere).
#include "kernels/normal_equations.h"

#include "kernels/reduce_normal_equations_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

namespace {
const KernelVariant<ReduceNormalEquationsFn>& selected() {
  static const KernelVariant<ReduceNormalEquationsFn>& v = best_variant(kReduceNormalEquationsVariants, cpu_features());
  return v;
}
}  // namespace

const char* reduce_normal_equations_selected() { return selected().name; }

void reduce_normal_equations(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  static const ReduceNormalEquationsFn fn = selected().fn;
  fn(rows, stride, n, out);
}

void ne_tail_tile(const float* rows, std::size_t stride, std::size_t begin, std::size_t count,
                  float tile[kNeComponents * kNeLanes]) {
  for (int k = 0; k < kNeComponents; ++k)
    for (std::size_t l = 0; l < static_cast<std::size_t>(kNeLanes); ++l)
      tile[k * kNeLanes + l] = l < count ? rows[k * stride + begin + l] : 0.0f;
}

int64_t ne_count_inliers(const float* w, std::size_t n) {
  int64_t count = 0;
  for (std::size_t i = 0; i < n; ++i) count += w[i] > 0.0f ? 1 : 0;
  return count;
}

void ne_finish(const NeLaneTotals& totals, int64_t inliers, NormalEquations* out) {
  for (int o = 0; o < kNeOutputs; ++o) {
    const double* t = totals + o * kNeLanes;
    out->upper[o] = ((t[0] + t[1]) + (t[2] + t[3])) + ((t[4] + t[5]) + (t[6] + t[7]));
  }
  out->inliers = inliers;
}

}  // namespace ef::kernels
