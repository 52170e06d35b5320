// The run-time choice of the element-wise, pooling, upsampling and softmax variants
// (nn/eltwise_kernels.h). The reference rows are the `<family>_ref` functions of nn/layers_ref.cpp.
#include "nn/eltwise_kernels.h"

namespace ef::nn {

void add_i8_ref_range(const AddArgs& a, std::size_t begin, std::size_t end) {
  if (begin >= end) return;
  AddArgs t = a;  // a 1 x 1 x (end - begin) view of the range
  t.a.data += begin;
  t.b.data += begin;
  t.out.data += begin;
  t.a.h = t.b.h = t.out.h = 1;
  t.a.w = t.b.w = t.out.w = 1;
  t.a.c = t.b.c = t.out.c = static_cast<int>(end - begin);
  add_i8_ref(t);
}

const kernels::KernelVariant<AddI8Fn>& add_i8_selected() {
  static const kernels::KernelVariant<AddI8Fn>& v = kernels::best_variant(kAddI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<PoolI8Fn>& maxpool_i8_selected() {
  static const kernels::KernelVariant<PoolI8Fn>& v = kernels::best_variant(kMaxPoolI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<PoolI8Fn>& avgpool_i8_selected() {
  static const kernels::KernelVariant<PoolI8Fn>& v = kernels::best_variant(kAvgPoolI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<ClampI8Fn>& clamp_i8_selected() {
  static const kernels::KernelVariant<ClampI8Fn>& v = kernels::best_variant(kClampI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<ConcatI8Fn>& concat_i8_selected() {
  static const kernels::KernelVariant<ConcatI8Fn>& v = kernels::best_variant(kConcatI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<UpsampleI8Fn>& upsample_nearest_i8_selected() {
  static const kernels::KernelVariant<UpsampleI8Fn>& v =
      kernels::best_variant(kUpsampleNearestI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<UpsampleI8Fn>& upsample_bilinear_i8_selected() {
  static const kernels::KernelVariant<UpsampleI8Fn>& v =
      kernels::best_variant(kUpsampleBilinearI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<ResizeI8Fn>& resize_bilinear_i8_selected() {
  static const kernels::KernelVariant<ResizeI8Fn>& v =
      kernels::best_variant(kResizeBilinearI8Variants, cpu_features());
  return v;
}
const kernels::KernelVariant<SoftmaxI8Fn>& softmax_i8_selected() {
  static const kernels::KernelVariant<SoftmaxI8Fn>& v = kernels::best_variant(kSoftmaxI8Variants, cpu_features());
  return v;
}

}  // namespace ef::nn
