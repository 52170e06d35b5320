// The loop nest of every SIMD concat_i8 variant, written once over the block types of
// nn/int8_simd.h (docs/model_format.md 3.4). Input-major: for each input, every pixel's channel run
// is copied or requantised into its slot of the output pixel. An input with the output's zero point
// and multiplier 1 is a plain copy: requantize(q - z, 1, z, -128, 127) == q exactly (q - z is an
// integer within the clamp bounds). Every other input goes through the float32 requantisation of
// requantize.h: q = round_half_even(clamp(float(q_i - z_i) * m_i, -128 - z, 127 - z)) + z.
#pragma once

#include <cstddef>
#include <cstdint>

#include "nn/int8_simd.h"
#include "nn/layers_ref.h"

namespace ef::nn {
namespace {

// One block of int32 values x (four quarters): round_half_even(clamp(float(x - bias) * m,
// -128 - zo, 127 - zo)) + zo as int8, exactly requantize(x - bias, m, zo, -128, 127). Shared with
// avgpool_i8_simd.h.
template <class V>
inline typename V::R requant_block(const typename V::Q (&x)[4], int32_t bias, float m, int32_t zo) {
  const typename V::Q vb = V::splat32(bias), vz = V::splat32(zo);
  const typename V::F vm = V::splatf(m), lo = V::splatf(float(-128 - zo)), hi = V::splatf(float(127 - zo));
  typename V::Q q[4];
  for (int j = 0; j < 4; ++j) {
    typename V::F y = V::mulf(V::cvtf(V::sub32(x[j], vb)), vm);
    y = V::minf(V::maxf(y, lo), hi);
    q[j] = V::add32(V::cvt_round(y), vz);
  }
  return V::narrow_s8(q[0], q[1], q[2], q[3]);
}

struct ConcatCopyOp {
  const int8_t* src;
  int8_t* dst;
  template <class V>
  void block(const V& v, int c) const { v.store(dst + c, v.load(src + c)); }
  void scalar(int c) const { dst[c] = src[c]; }
};

struct ConcatRequantOp {
  const int8_t* src;
  int8_t* dst;
  int32_t zi, zo;
  float m;
  template <class V>
  void block(const V& v, int c) const {
    const typename V::R b = v.load(src + c);
    const typename V::Q x[4] = {V::template widen<0>(b), V::template widen<1>(b), V::template widen<2>(b),
                                V::template widen<3>(b)};
    v.store(dst + c, requant_block<V>(x, zi, m, zo));
  }
  void scalar(int c) const { dst[c] = requantize(int32_t(src[c]) - zi, m, zo, -128, 127); }
};

template <class Blocks>
void concat_channels(const ConcatArgs& a) {
  // Everything the pixel loop needs is copied into locals first: the stores go through int8_t,
  // which may alias anything, so fields read through `a` would be reloaded (and the constants
  // broadcast again) for every pixel.
  const std::ptrdiff_t pixels = std::ptrdiff_t(a.out.h) * a.out.w;
  const int out_c = a.out.c;
  const int32_t zo = a.out.zero_point;
  int8_t* const out = a.out.data;
  int offset = 0;  // channel of the output where input k starts
  for (int k = 0; k < a.count; ++k) {
    const int8_t* const src = a.in[k].data;
    const int c = a.in[k].c;
    const int32_t zi = a.in[k].zero_point;
    const float m = a.rq[k].multiplier;
    int8_t* const dst = out + offset;
    if (m == 1.0f && zi == zo) {
      for (std::ptrdiff_t p = 0; p < pixels; ++p) Blocks::run(ConcatCopyOp{src + p * c, dst + p * out_c}, 0, c);
    } else {
      for (std::ptrdiff_t p = 0; p < pixels; ++p)
        Blocks::run(ConcatRequantOp{src + p * c, dst + p * out_c, zi, zo, m}, 0, c);
    }
    offset += c;
  }
}

}  // namespace
}  // namespace ef::nn
