// The loop nest of every SIMD resize_bilinear_i8 variant, written once over the block types of
// nn/int8_simd.h (docs/model_format.md 3.9). NHWC, vectorised over channels; the taps of every
// output row and column come precomputed (ResizeArgs::taps_y / taps_x, nn/resize_taps.h).
//
// Per output pixel with row taps (i0y, i1y, wy) and column taps (i0x, i1x, wx), weights in 1/2048:
//   h0 = (2048 - wx) u[i0y, i0x] + wx u[i0y, i1x]       u = q + 128; h < 2^19 (lerp_u8: PMADDWD /
//   h1 = (2048 - wx) u[i1y, i0x] + wx u[i1y, i1x]       UMLAL, exact in int32)
//   num = (h0 << 11) + wy (h1 - h0)                     = (2048 - wy) h0 + wy h1 <= 2^22 * 255
//   q  = ((num + 2^21) >> 22) - 128                     (narrow_u8_flip32)
// which is the reference's arithmetic term for term: one 32-bit multiply per lane instead of two.
// A pixel whose two weights are 0 (every pixel of a 1 x 1 -> H x W broadcast, the corners, and any
// output that falls on an input pixel) is that input pixel: a copy of its C bytes, as the formula
// gives (num = 2^22 u).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "nn/int8_simd.h"
#include "nn/layers_ref.h"

namespace ef::nn {
namespace {

struct ResizeOp {
  const int8_t *p00, *p01, *p10, *p11;  // rows i0y / i1y, columns i0x / i1x
  int8_t* dst;
  int32_t wx, wy;  // weights of i1x and i1y in 1/2048

  template <class V, int k>
  static typename V::Q quarter(typename V::R a00, typename V::R a01, typename V::R a10, typename V::R a11,
                               typename V::LW wxv, typename V::Q wyv) {
    const typename V::Q h0 = V::template lerp_u8<k>(a00, a01, wxv);
    const typename V::Q h1 = V::template lerp_u8<k>(a10, a11, wxv);
    const typename V::Q num = V::add32(V::template shl32<kResizeWeightBits>(h0), V::mul32(V::sub32(h1, h0), wyv));
    return V::template shr32<kResizeShift>(V::add32(num, V::splat32(1 << (kResizeShift - 1))));
  }
  template <class V>
  void block(const V& v, int c) const {
    const typename V::R a00 = v.load(p00 + c), a01 = v.load(p01 + c);
    const typename V::R a10 = v.load(p10 + c), a11 = v.load(p11 + c);
    const typename V::LW wxv = V::lerp_weights(kResizeOne - wx, wx);
    const typename V::Q wyv = V::splat32(wy);
    v.store(dst + c, V::narrow_u8_flip32(quarter<V, 0>(a00, a01, a10, a11, wxv, wyv),
                                         quarter<V, 1>(a00, a01, a10, a11, wxv, wyv),
                                         quarter<V, 2>(a00, a01, a10, a11, wxv, wyv),
                                         quarter<V, 3>(a00, a01, a10, a11, wxv, wyv)));
  }
  // The reference's arithmetic, for channels below the narrowest block.
  void scalar(int c) const {
    const int32_t row0 = (kResizeOne - wx) * (p00[c] + 128) + wx * (p01[c] + 128);
    const int32_t row1 = (kResizeOne - wx) * (p10[c] + 128) + wx * (p11[c] + 128);
    const int32_t num = (kResizeOne - wy) * row0 + wy * row1;
    dst[c] = static_cast<int8_t>(((num + (1 << (kResizeShift - 1))) >> kResizeShift) - 128);
  }
};

template <class Blocks>
void resize_bilinear_rows(const ResizeArgs& a) {
  const int C = a.out.c;
  const std::ptrdiff_t in_row = std::ptrdiff_t(a.in.w) * C;
  for (int oy = 0; oy < a.out.h; ++oy) {
    const ResizeTap ty = a.taps_y[oy];
    const int8_t* r0 = a.in.data + ty.i0 * in_row;
    const int8_t* r1 = a.in.data + ty.i1 * in_row;
    int8_t* dst = a.out.data + std::ptrdiff_t(oy) * a.out.w * C;
    for (int ox = 0; ox < a.out.w; ++ox, dst += C) {
      const ResizeTap tx = a.taps_x[ox];
      const std::ptrdiff_t c0 = std::ptrdiff_t(tx.i0) * C, c1 = std::ptrdiff_t(tx.i1) * C;
      if (tx.w == 0 && ty.w == 0) {  // on an input pixel: num = 2^22 u exactly
        std::memcpy(dst, r0 + c0, std::size_t(C));
        continue;
      }
      Blocks::run(ResizeOp{r0 + c0, r0 + c1, r1 + c0, r1 + c1, dst, tx.w, ty.w}, 0, C);
    }
  }
}

}  // namespace
}  // namespace ef::nn
