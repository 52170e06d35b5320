// The loop nests of every SIMD upsample_nearest_i8 / upsample_bilinear_i8 variant, written once over
// the block types of nn/int8_simd.h (docs/model_format.md 3.5 and 3.7). The output is the input
// times the factor f in both axes (the loader checks it); NHWC, vectorised over channels.
//
// Nearest: each input pixel's channels are loaded once and stored f times; an output row whose
// source row is the previous output row's is a copy of that row.
//
// Bilinear, f <= 8: per output pixel the four source pixels and the weights of the reference
// (half-pixel centres, F = 2f, D = F * F), computed separably in 16-bit lanes:
//   h_row = (F - rx) * q[row, i0x] + rx * q[row, i1x]                   |h| <= 128 F   (exact)
//   n     = (F - ry) * h_i0y + ry * h_i1y + 128 D + D / 2                mod 2^16; the true n is
//                                                                       in [D/2, 255 D + D/2] < 2^16
//   q     = floor(n / D) - 128                                          (bilinear_div, exact)
// which is the reference's (sum w * (q + 128) + D/2) / D - 128: the weights sum to D, so the +128 of
// every tap moves into the constant. The taps come from an incremental walk (AxisTaps) instead of a
// division per pixel. f > 8 would overflow 16-bit lanes (255 D >= 2^16): the reference runs instead
// (the shipped network uses f = 2; the format allows up to 16).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "nn/int8_simd.h"
#include "nn/layers_ref.h"

namespace ef::nn {
namespace {

// Bilinear taps of output indices 0, 1, 2... along an axis of input size n, as bilinear_tap of
// layers_ref.cpp: t = 2o + 1 - f clamped at 0, i0 = t div 2f, r = t mod 2f, i1 = min(i0 + 1, n - 1).
// t grows by 2 per step and 2 <= 2f, so r wraps at most once per step.
struct AxisTaps {
  int f2, last;
  int t;      // 2o + 1 - f, unclamped
  int i0, r;  // of max(t, 0)
  AxisTaps(int f, int n) : f2(2 * f), last(n - 1), t(1 - f), i0(0), r(0) {}
  int i1() const { return i0 < last ? i0 + 1 : last; }
  void next() {
    t += 2;
    if (t <= 0) return;
    r = t < 2 ? t : r + 2;  // the first positive t is 1 (f even) or 2 (f odd, the previous r was 0)
    if (r >= f2) {
      r -= f2;
      ++i0;
    }
  }
};

struct BilinearOp {
  const int8_t *p00, *p01, *p10, *p11;  // rows i0y / i1y, columns i0x / i1x
  int8_t* dst;
  int wx0, wx1, wy0, wy1;  // F - rx, rx, F - ry, ry
  int d;                   // F * F
  BilinearDiv div;
  template <class V>
  void block(const V& v, int c) const {
    const typename V::R q00 = v.load(p00 + c), q01 = v.load(p01 + c);
    const typename V::R q10 = v.load(p10 + c), q11 = v.load(p11 + c);
    const typename V::HW wx = V::hweights(wx0, wx1);
    const typename V::W wy0v = V::splat16(wy0), wy1v = V::splat16(wy1), bias = V::splat16(128 * d + d / 2);
    const typename V::Div dv = V::make_div(div);
    const typename V::W lo = V::add16(
        V::add16(V::mul16(V::hmix_lo(q00, q01, wx), wy0v), V::mul16(V::hmix_lo(q10, q11, wx), wy1v)), bias);
    const typename V::W hi = V::add16(
        V::add16(V::mul16(V::hmix_hi(q00, q01, wx), wy0v), V::mul16(V::hmix_hi(q10, q11, wx), wy1v)), bias);
    v.store(dst + c, V::narrow_u8_flip(V::div16(lo, dv), V::div16(hi, dv)));
  }
  // The reference's arithmetic, for channels below the narrowest block.
  void scalar(int c) const {
    const int32_t num = wy0 * wx0 * (p00[c] + 128) + wy0 * wx1 * (p01[c] + 128) + wy1 * wx0 * (p10[c] + 128) +
                        wy1 * wx1 * (p11[c] + 128);
    dst[c] = static_cast<int8_t>((num + d / 2) / d - 128);
  }
};

// Wide: a 16-lane block type for 8 < C < 16 (or void). Such a pixel is then one 16-byte block that
// reads the first 16 - C bytes of the next input pixel and writes garbage into the first 16 - C bytes
// of the next output pixel, which the loop computes afterwards (output pixels go in memory order and
// input and output never overlap). Only where the 16 bytes stay inside both tensors; elsewhere (the
// last pixels) the Blocks path. One block instead of two overlapping 8-byte ones: the 14 channels of
// the shipped network's largest upsampling.
template <class Blocks, class Wide = void>
void upsample_bilinear_rows(const UpsampleArgs& a) {
  const int f = a.factor;
  if (f > kBilinearSimdMaxFactor) {
    upsample_bilinear_i8_ref(a);
    return;
  }
  const int C = a.out.c, f2 = 2 * f;
  const BilinearDiv div = bilinear_div(f);
  const std::ptrdiff_t in_row = std::ptrdiff_t(a.in.w) * C;
  const int8_t* const in_end = a.in.data + a.in.h * in_row;
  int8_t* const out_end = a.out.data + std::ptrdiff_t(a.out.h) * a.out.w * C;
  bool wide = false;
  if constexpr (!std::is_void_v<Wide>) wide = C > 8 && C < Wide::kLanes;
  AxisTaps ty(f, a.in.h);
  for (int oy = 0; oy < a.out.h; ++oy, ty.next()) {
    const int8_t* r0 = a.in.data + ty.i0 * in_row;
    const int8_t* r1 = a.in.data + ty.i1() * in_row;
    int8_t* dst = a.out.data + std::ptrdiff_t(oy) * a.out.w * C;
    AxisTaps tx(f, a.in.w);
    for (int ox = 0; ox < a.out.w; ++ox, tx.next(), dst += C) {
      const std::ptrdiff_t c0 = std::ptrdiff_t(tx.i0) * C, c1 = std::ptrdiff_t(tx.i1()) * C;
      const BilinearOp op{r0 + c0, r0 + c1, r1 + c0, r1 + c1, dst, f2 - tx.r, tx.r, f2 - ty.r, ty.r, f2 * f2, div};
      if constexpr (!std::is_void_v<Wide>) {
        // r1 + c1 is the last of the four source pixels in memory.
        if (wide && op.p11 + Wide::kLanes <= in_end && dst + Wide::kLanes <= out_end) {
          op.block(Wide{}, 0);
          continue;
        }
      }
      Blocks::run(op, 0, C);
    }
  }
}

struct NearestOp {
  const int8_t* src;  // one input pixel
  int8_t* dst;        // the first of its f output pixels
  int f, C;
  template <class V>
  void block(const V& v, int c) const {
    const typename V::R x = v.load(src + c);
    for (int k = 0; k < f; ++k) v.store(dst + std::ptrdiff_t(k) * C + c, x);
  }
  void scalar(int c) const {
    for (int k = 0; k < f; ++k) dst[std::ptrdiff_t(k) * C + c] = src[c];
  }
};

template <class Blocks>
void upsample_nearest_rows(const UpsampleArgs& a) {
  const int f = a.factor, C = a.out.c;
  const std::size_t out_row = std::size_t(a.out.w) * C;
  for (int oy = 0; oy < a.out.h; ++oy) {
    int8_t* dst = a.out.data + oy * out_row;
    if (oy % f != 0) {  // same source row as the row above
      std::memcpy(dst, dst - out_row, out_row);
      continue;
    }
    const int8_t* src = a.in.data + std::ptrdiff_t(oy / f) * a.in.w * C;
    for (int x = 0; x < a.in.w; ++x)
      Blocks::run(NearestOp{src + std::ptrdiff_t(x) * C, dst + std::ptrdiff_t(x) * f * C, f, C}, 0, C);
  }
}

}  // namespace
}  // namespace ef::nn
