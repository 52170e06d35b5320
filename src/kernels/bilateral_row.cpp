// Run-time dispatch of bilateral_row.
#include "kernels/bilateral_row.h"

#include "kernels/bilateral_row_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<BilateralRowFn>& selected() {
  static const KernelVariant<BilateralRowFn>& v = best_variant(kBilateralRowVariants, cpu_features());
  return v;
}
}  // namespace

const char* bilateral_row_selected() { return selected().name; }

void bilateral_row(const BilateralRow& b, int width, float* out) {
  static const BilateralRowFn fn = selected().fn;
  fn(b, width, out);
}

}  // namespace ef::kernels
