// The loop of every SIMD clamp_i8 variant, written once over the block types of nn/int8_simd.h:
// the tensor as one flat run of bytes, out = min(max(in, out_min), out_max) (docs/model_format.md
// 3.5). out may alias in: every block is loaded before it is stored, and the overlapping last block
// of ChannelBlocks re-clamps bytes that are already clamped, which leaves them unchanged.
#pragma once

#include <cstddef>
#include <cstdint>

#include "nn/int8_simd.h"
#include "nn/layers_ref.h"

namespace ef::nn {
namespace {

struct ClampOp {
  const int8_t* in;
  int8_t* out;
  int32_t lo, hi;  // lo <= hi (the loader checks the output range)
  template <class V>
  void block(const V& v, int i) const {
    v.store(out + i, V::min8(V::max8(v.load(in + i), V::splat8(lo)), V::splat8(hi)));
  }
  void scalar(int i) const {
    const int32_t x = in[i];
    out[i] = static_cast<int8_t>(x < lo ? lo : (x > hi ? hi : x));
  }
};

template <class Blocks>
void clamp_flat(const ClampArgs& a) {
  // h * w * c <= 2^26 (the loader's tensor limit): an int index.
  const int n = a.out.h * a.out.w * a.out.c;
  Blocks::run(ClampOp{a.in.data, a.out.data, a.out_min, a.out_max}, 0, n);
}

}  // namespace
}  // namespace ef::nn
