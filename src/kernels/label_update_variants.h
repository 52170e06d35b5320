// Every variant of label_update (internal: the dispatcher, tests and benchmark use it).
// Contract of each variant: that of ef::kernels::label_update (kernels/label_update.h).
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/label_update.h"
#include "kernels/variants.h"

namespace ef::kernels {

using LabelUpdateFn = void (*)(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n);

#define EF_KERNEL_VARIANT(fn, isa) \
  void fn(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n);
#include "kernels/label_update.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<LabelUpdateFn> kLabelUpdateVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/label_update.inc"
#undef EF_KERNEL_VARIANT
};

}  // namespace ef::kernels
