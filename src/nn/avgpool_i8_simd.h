// The loop nest of every SIMD avgpool_i8 variant, written once over the block types of
// nn/int8_simd.h (docs/model_format.md 3.6): for each output pixel, the window clipped to the input
// (clip_window of nn/maxpool_i8_simd.h: padding is skipped and not counted), and per block of
// channels the int32 sum of the n window bytes, then
//   requantize(sum - n * z_in, m_n, z_out, -128, 127)
// which is the reference's sum of (q - z_in) (the same integer; |sum| <= 255 * 256 * 256 < 2^31, the
// largest window being a global pool of 256 x 256, and |n * z_in| <= 128 * 65536). The multiplier of
// a window of n positions is requant_by_count[n - requant_count_base] (a global pool's table holds its
// one count only).
#pragma once

#include <cstddef>
#include <cstdint>

#include "nn/concat_i8_simd.h"
#include "nn/int8_simd.h"
#include "nn/layers_ref.h"
#include "nn/maxpool_i8_simd.h"

namespace ef::nn {
namespace {

struct AvgPoolOp {
  const Window& win;
  int8_t* dst;
  int32_t bias;  // n * z_in
  int32_t zo;
  float m;       // requant_by_count[n - 1]
  template <class V>
  void block(const V& v, int c) const {
    typename V::Q x[4] = {V::zero32(), V::zero32(), V::zero32(), V::zero32()};
    for (int y = 0; y < win.ny; ++y) {
      const int8_t* p = win.src + y * win.row + c;
      for (int i = 0; i < win.nx; ++i, p += win.px) {
        const typename V::R b = v.load(p);
        x[0] = V::add32(x[0], V::template widen<0>(b));
        x[1] = V::add32(x[1], V::template widen<1>(b));
        x[2] = V::add32(x[2], V::template widen<2>(b));
        x[3] = V::add32(x[3], V::template widen<3>(b));
      }
    }
    v.store(dst + c, requant_block<V>(x, bias, m, zo));
  }
  void scalar(int c) const {
    int32_t sum = 0;
    for (int y = 0; y < win.ny; ++y)
      for (int i = 0; i < win.nx; ++i) sum += win.src[y * win.row + i * win.px + c];
    dst[c] = requantize(sum - bias, m, zo, -128, 127);
  }
};

// The loader keeps every window at least one input position wide (pads smaller than the kernel),
// so n >= 1, as the reference assumes too.
template <class Blocks>
void avgpool_rows(const PoolArgs& a) {
  const int C = a.out.c;
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox) {
      const Window win = clip_window(a, oy, ox);
      const int n = win.ny * win.nx;
      int8_t* dst = a.out.data + (std::ptrdiff_t(oy) * a.out.w + ox) * C;
      Blocks::run(AvgPoolOp{win, dst, n * a.in.zero_point, a.out.zero_point, a.requant_by_count[n - a.requant_count_base].multiplier}, 0, C);
    }
}

}  // namespace
}  // namespace ef::nn
