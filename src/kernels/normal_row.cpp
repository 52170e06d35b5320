// Run-time dispatch of normal_row.
#include "kernels/normal_row.h"

#include "kernels/normal_row_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<NormalRowFn>& selected() {
  static const KernelVariant<NormalRowFn>& v = best_variant(kNormalRowVariants, cpu_features());
  return v;
}
}  // namespace

const char* normal_row_selected() { return selected().name; }

void normal_row(const NormalRow& r, int x_begin, int x_end, float* normal) {
  static const NormalRowFn fn = selected().fn;
  fn(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
