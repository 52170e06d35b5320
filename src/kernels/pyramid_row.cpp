// Run-time dispatch of pyramid_row.
#include "kernels/pyramid_row.h"

#include "kernels/pyramid_row_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<PyramidRowFn>& selected() {
  static const KernelVariant<PyramidRowFn>& v = best_variant(kPyramidRowVariants, cpu_features());
  return v;
}
}  // namespace

const char* pyramid_row_selected() { return selected().name; }

void pyramid_row(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  static const PyramidRowFn fn = selected().fn;
  fn(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
