// The conv_i8 tile for x86 without VNNI (SSE4.1 and AVX2), written once over a small vector traits
// class. PMADDWD multiplies int16 pairs and adds each pair into an int32 lane, so the input is
// widened to int16 as it is read, 8 channels at a time, and each pair of channels is broadcast to
// every lane (one PSHUFD) and multiplied by the pair's weights of `lanes` output channels.
// Exact: int16 products of int8 values cannot saturate, unlike PMADDUBSW's int16 pair sums.
// Weights [tap][cin/2][lanes][2] int16 (ConvPackLayout{lanes, 2, 2, 8, 0}); raw input bytes, the
// zero point is folded into the biases by the pack.
//
// Traits V provides: type R (register), kLanes, kRegisters,
//   R widen(uint64_t eight_bytes)  -> eight int16 (repeated in each 128-bit half for AVX2)
//   template <int J> R pair(R x)   -> the J-th int16 pair in every 32-bit lane
//   R madd_add(R acc, R x, const int16_t* w)   acc + pmaddwd(x, w[0 .. 2 * kLanes))
//   R load_i32(const int32_t*), void store_requantized(R acc, const float* mult, ...)
#pragma once

#include <cstring>

#include "nn/conv_i8_simd.h"

namespace ef::nn {
namespace {

template <class V>
struct PmaddwdTile {
  static constexpr int kMaxPanels = 4;
  // MR x NV accumulators plus the widened pixel and one broadcast pair in V::kRegisters.
  template <int NV>
  static constexpr int pixels() {
    return (V::kRegisters - 3) / NV < 8 ? (V::kRegisters - 3) / NV : 8;
  }

  template <int NV, int MR>
  static void run(const TileJob& j) {
    using R = typename V::R;
    const ConvArgs& a = *j.a;
    const ConvPackHeader& h = conv_header(j.blob);
    constexpr int L = V::kLanes;
    const int32_t* bias = conv_bias(j.blob) + j.panel0 * L;
    const int16_t* w[NV];
    for (int v = 0; v < NV; ++v) w[v] = reinterpret_cast<const int16_t*>(conv_panel(j.blob, j.panel0 + v));

    R acc[MR][NV];
    for (int v = 0; v < NV; ++v) {
      const R b = V::load_i32(bias + L * v);
      for (int m = 0; m < MR; ++m) acc[m][v] = b;
    }
    const int chunks = h.cin_pad / 8, tail = h.cin % 8;
    const int full = tail ? chunks - 1 : chunks;
    constexpr int kChunkStride = 4 * 2 * L;  // int16 weights per 8-channel chunk of one panel
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      for (int kx = 0; kx < a.kernel_w; ++kx) {
        const int8_t* p[MR];
        tap_pointers<MR>(j, ky, kx, p);
        for (int c = 0; c < chunks; ++c) {
          for (int m = 0; m < MR; ++m) {
            uint64_t bytes;
            if (c < full) std::memcpy(&bytes, p[m] + 8 * c, 8);
            else bytes = load_tail8(p[m] + 8 * c, tail);  // channels past cin have zero weights
            const R x = V::widen(bytes);
            const R x0 = V::template pair<0>(x), x1 = V::template pair<1>(x);
            const R x2 = V::template pair<2>(x), x3 = V::template pair<3>(x);
            for (int v = 0; v < NV; ++v) {
              const int16_t* wc = w[v] + c * kChunkStride;
              R s = V::madd_add(acc[m][v], x0, wc);
              s = V::madd_add(s, x1, wc + 2 * L);
              s = V::madd_add(s, x2, wc + 4 * L);
              acc[m][v] = V::madd_add(s, x3, wc + 6 * L);
            }
          }
        }
        for (int v = 0; v < NV; ++v) w[v] += std::size_t(h.k_steps) * 2 * L;
      }
    }

    const float* mult = conv_mult(j.blob) + j.panel0 * L;
    for (int v = 0; v < NV; ++v) {
      const int c0 = (j.panel0 + v) * L;
      const int valid = h.cout - c0 < L ? h.cout - c0 : L;
      for (int m = 0; m < MR; ++m) {
        if (m >= j.npix) break;
        int8_t* dst = a.out.data + (std::ptrdiff_t(j.oy) * a.out.w + j.ox0 + m) * a.out.c + c0;
        V::store_requantized(acc[m][v], mult + L * v, a.out.zero_point, a.out_min, a.out_max, dst, valid);
      }
    }
  }
};

}  // namespace
}  // namespace ef::nn
