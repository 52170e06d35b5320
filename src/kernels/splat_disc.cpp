// Run-time dispatch of splat_disc.
#include "kernels/splat_disc.h"

#include "kernels/splat_disc_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<SplatDiscFn>& selected() {
  static const KernelVariant<SplatDiscFn>& v = best_variant(kSplatDiscVariants, cpu_features());
  return v;
}
}  // namespace

const char* splat_disc_selected() { return selected().name; }

void splat_disc(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner, int width) {
  static const SplatDiscFn fn = selected().fn;
  fn(d, ray_x, ray_y, key, winner, width);
}

}  // namespace ef::kernels
