// Run-time dispatch of label_update: the best variant for this CPU (capped by EF_ISA) is chosen on
// the first call and kept in a function-local static (thread-safe initialisation).
#include "kernels/label_update.h"

#include "kernels/label_update_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<LabelUpdateFn>& selected() {
  static const KernelVariant<LabelUpdateFn>& v = best_variant(kLabelUpdateVariants, cpu_features());
  return v;
}
}  // namespace

const char* label_update_selected() { return selected().name; }

void label_update(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n) {
  static const LabelUpdateFn fn = selected().fn;
  fn(store, obs, pairs, n);
}

void label_merge(uint8_t* keep, const uint8_t* other) {
  unsigned t[kLabelUpdateClasses];
  unsigned m = 255;
  for (int c = 0; c < kLabelUpdateClasses; ++c) {
    const unsigned sum = unsigned(keep[c]) + unsigned(other[c]);
    t[c] = sum > 255 ? 255 : sum;
    if (t[c] < m) m = t[c];
  }
  for (int c = 0; c < kLabelUpdateClasses; ++c) keep[c] = static_cast<uint8_t>(t[c] - m);
  keep[14] = 0;
  keep[15] = 0;
}

}  // namespace ef::kernels
