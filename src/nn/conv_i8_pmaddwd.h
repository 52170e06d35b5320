// The conv_i8 tile for x86 without VNNI (SSE4.1 and AVX2), written once over a small vector traits
// class. PMADDWD multiplies int16 pairs and adds each pair into an int32 lane, so for each tap the
// tile first widens up to 64 input channels of each of its MR pixels to int16 in a stack buffer,
// then broadcasts one int16 pair at a time from there (a load, no shuffle) and multiplies it by the
// pair's weights of `lanes` output channels in each of NV panels.
// Exact: int16 products of int8 values cannot saturate, unlike PMADDUBSW's int16 pair sums.
// Weights [tap][cin/2][lanes][2] int16 (ConvPackLayout{lanes, 2, 2, 8, 0}); raw input bytes, the
// zero point is folded into the biases by the pack.
//
// Traits V provides: type R (register), kLanes, kRegisters,
//   void widen8(uint64_t eight_bytes, int16_t* dst)  eight int8 -> eight int16 at dst
//   R broadcast_pair(const int16_t* p)               the int16 pair at p in every 32-bit lane
//   R madd_add(R acc, R x, const int16_t* w)          acc + pmaddwd(x, w[0 .. 2 * kLanes))
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
  // MR x NV accumulators plus one broadcast pair within V::kRegisters; weights stay in memory
  // operands (L1), each read by MR pixels.
  template <int NV>
  static constexpr int pixels() {
    return (V::kRegisters - 2) / NV < 8 ? (V::kRegisters - 2) / NV : 8;
  }

  template <int NV, int MR>
  static void run(const TileJob& j) {
    using R = typename V::R;
    const ConvArgs& a = *j.a;
    const ConvPackHeader& h = conv_header(j.blob);
    constexpr int L = V::kLanes;
    constexpr int kBlock = 64;  // input channels widened per pass (2 KiB of int16 for MR = 8)
    const int32_t* bias = conv_bias(j.blob) + j.panel0 * L;
    const int16_t* w[NV];
    for (int v = 0; v < NV; ++v) w[v] = reinterpret_cast<const int16_t*>(conv_panel(j.blob, j.panel0 + v));

    R acc[MR][NV];
    for (int v = 0; v < NV; ++v) {
      const R b = V::load_i32(bias + L * v);
      for (int m = 0; m < MR; ++m) acc[m][v] = b;
    }
    alignas(64) int16_t wide[MR][kBlock];
    const int cin = h.cin, cin_pad = h.cin_pad;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      for (int kx = 0; kx < a.kernel_w; ++kx) {
        const int8_t* p[MR];
        tap_pointers<MR>(j, ky, kx, p);
        for (int c0 = 0; c0 < cin_pad; c0 += kBlock) {
          const int n = cin_pad - c0 < kBlock ? cin_pad - c0 : kBlock;  // a multiple of 8
          for (int m = 0; m < MR; ++m) {
            for (int c = 0; c < n; c += 8) {
              uint64_t bytes;
              const int left = cin - (c0 + c);
              if (left >= 8) std::memcpy(&bytes, p[m] + c0 + c, 8);
              else bytes = load_tail8(p[m] + c0 + c, left);  // channels past cin have zero weights
              V::widen8(bytes, wide[m] + c);
            }
          }
          for (int k = 0; k < n; k += 2) {
            const std::size_t wo = std::size_t(c0 + k) * L;  // pair (c0 + k) / 2, 2 * L int16 per pair
            for (int m = 0; m < MR; ++m) {
              const R x = V::broadcast_pair(wide[m] + k);
              for (int v = 0; v < NV; ++v) acc[m][v] = V::madd_add(acc[m][v], x, w[v] + wo);
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
