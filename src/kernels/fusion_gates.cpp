// Run-time dispatch of fusion_gates.
#include "kernels/fusion_gates.h"

#include "kernels/fusion_gates_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<FusionGatesFn>& selected() {
  static const KernelVariant<FusionGatesFn>& v = best_variant(kFusionGatesVariants, cpu_features());
  return v;
}
}  // namespace

const char* fusion_gates_selected() { return selected().name; }

void fusion_gates(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  static const FusionGatesFn fn = selected().fn;
  fn(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
