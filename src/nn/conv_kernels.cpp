// The reference rows of the convolution tables and the run-time choice.
#include "nn/conv_kernels.h"

namespace ef::nn {

namespace {
std::size_t no_packing(const ConvShape&) { return 0; }
void pack_nothing(const ConvShape&, const ConvParams&, void*) {}
}  // namespace

// The references read the file layout straight from ConvArgs::weights.
const ConvKernel conv_i8_ref = {no_packing, pack_nothing, conv2d_i8_ref};
const ConvKernel dwconv_i8_ref = {no_packing, pack_nothing, dwconv2d_i8_ref};

const kernels::KernelVariant<ConvKernelPtr>& conv_i8_selected() {
  static const kernels::KernelVariant<ConvKernelPtr>& v = kernels::best_variant(kConvI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<ConvKernelPtr>& dwconv_i8_selected() {
  static const kernels::KernelVariant<ConvKernelPtr>& v = kernels::best_variant(kDwConvI8Variants, cpu_features());
  return v;
}

}  // namespace ef::nn
