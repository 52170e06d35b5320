// Run-time dispatch of dot_i8: the best variant for this CPU (capped by EF_ISA) is chosen on the
// first call and kept in a function-local static (thread-safe initialisation).
#include "kernels/dot_i8.h"

#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<DotI8Fn>& selected() {
  static const KernelVariant<DotI8Fn>& v = best_variant(kDotI8Variants, cpu_features());
  return v;
}
}  // namespace

const char* dot_i8_selected() { return selected().name; }

int32_t dot_i8(const int8_t* a, const int8_t* b, std::size_t n) {
  static const DotI8Fn fn = selected().fn;
  return fn(a, b, n);
}

}  // namespace ef::kernels
