// Run-time dispatch of gradient_fill_row.
#include "kernels/gradient_fill_row.h"

#include "kernels/gradient_fill_row_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<GradientFillRowFn>& selected() {
  static const KernelVariant<GradientFillRowFn>& v = best_variant(kGradientFillRowVariants, cpu_features());
  return v;
}
}  // namespace

const char* gradient_fill_row_selected() { return selected().name; }

void gradient_fill_row(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y, float* filled) {
  static const GradientFillRowFn fn = selected().fn;
  fn(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
