// The run-time choice of the element-wise / pooling variants (nn/eltwise_kernels.h). The reference
// rows are add_i8_ref and maxpool_i8_ref in nn/layers_ref.cpp.
#include "nn/eltwise_kernels.h"

namespace ef::nn {

const kernels::KernelVariant<AddI8Fn>& add_i8_selected() {
  static const kernels::KernelVariant<AddI8Fn>& v = kernels::best_variant(kAddI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<PoolI8Fn>& maxpool_i8_selected() {
  static const kernels::KernelVariant<PoolI8Fn>& v = kernels::best_variant(kMaxPoolI8Variants, cpu_features());
  return v;
}

}  // namespace ef::nn
