// Run-time dispatch of depth_u16_to_metres: the best variant for this CPU (capped by EF_ISA) is
// chosen on the first call and kept in a function-local static (thread-safe initialisation).
#include "kernels/depth_convert.h"

#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<DepthU16ToMetresFn>& selected() {
  static const KernelVariant<DepthU16ToMetresFn>& v = best_variant(kDepthU16ToMetresVariants, cpu_features());
  return v;
}
}  // namespace

const char* depth_u16_to_metres_selected() { return selected().name; }

void depth_u16_to_metres(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                         uint16_t max_valid_raw) {
  static const DepthU16ToMetresFn fn = selected().fn;
  fn(src, dst, n, metres_per_unit, max_valid_raw);
}

}  // namespace ef::kernels
