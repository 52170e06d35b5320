// Internal to the SIMD variants of dwconv_i8 (nn/conv_kernels.h): the packed layout, the pack, and the
// row loop, written once over a small per-ISA traits type. Internal linkage throughout (anonymous
// namespace): each ISA file compiles its own copy with its own flags (the rule in kernels/variants.h).
//
// Arithmetic. The reference accumulates sum (q - z_in) * w over the taps inside the input. Here the
// zero-point term is folded into the bias at pack time,
//     acc = (bias - z_in * sum_t w_t) + sum_t q_t * w_t,
// and a tap outside the input reads a "pad row" of C bytes equal to z_in (stored in the blob), whose
// contribution z_in * w_t cancels its share of the fold. Every tap therefore has a valid pointer and
// the inner loop has no branches; the int32 result equals the reference's exactly (no intermediate
// can overflow: |bias| <= 2^30 and |q * w| * 961 taps < 2^24). The requantisation is then
// nn/requantize.h lane by lane (convert, multiply, max, min, convert with round-half-even, add zp).
//
// Packed blob, every section 64-byte aligned, Cp = C rounded up to 16 (the widest block, AVX-512) so
// that the bias, multiplier and weight loads of a channel tail stay inside the blob:
//     int32  bias[Cp]            bias[c] - z_in * sum_t w[c][t]   (0 in the padding)
//     float  multiplier[Cp]      Requant::multiplier               (1 in the padding)
//     int8   pad_row[Cp]         z_in
//     int16  weights[P][Cp][2]   P = ceil(taps / 2) tap pairs; weights[p][c][k] = w[c][2p + k],
//                                0 for the missing tap 2p + 1 == taps when taps is odd
// Taps are t = ky * kw + kx, as in the file layout [c][kh][kw]. Interleaving the two taps of a pair per
// channel is what the int16 pair multiply-add instructions want (PMADDWD, VPDPWSSD); NEON splits the
// pairs again with one LD2.
//
// A traits type V provides:
//   kWidth                channels per block
//   kMasked               true: partial blocks via lane masks (mac2_n, store_n); false: the last
//                         C mod kWidth channels go through the scalar tail below
//   Acc                   int32 accumulators of one block
//   load_bias(b)          Acc from kWidth int32
//   mac2(acc, x0, x1, w)  acc[c] += x0[c] * w[2c] + x1[c] * w[2c + 1] for c < kWidth (x: int8 input,
//                         w: 2 kWidth int16)
//   store(acc, m, rq, d)  requantises acc with multipliers m[0 .. kWidth) and writes kWidth int8 to d
//   mac2_n / store_n      the same with only the first n channels of x0, x1, d touched (kMasked only)
// Loads of bias, multipliers and weights may always be full blocks (the blob is padded); loads of the
// input and stores of the output must stay within the tensors (tests use exact-size buffers).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "nn/conv_kernels.h"
#include "nn/requantize.h"

namespace ef::nn {
namespace {

constexpr int kDwChannelPad = 16;  // Cp granularity, channels
constexpr int kDwMaxKernel = 31;   // docs/model_format.md: kernel 1..31 per axis
constexpr int kDwMaxTaps = kDwMaxKernel * kDwMaxKernel;

constexpr std::size_t dw_round64(std::size_t bytes) { return (bytes + 63) & ~std::size_t{63}; }

// Byte offsets of the sections of the blob for one layer.
struct DwLayout {
  int c = 0, cp = 0;       // channels, padded channels
  int taps = 0, pairs = 0;  // kh * kw, ceil(taps / 2)
  std::size_t bias = 0, mult = 0, pad_row = 0, weights = 0, bytes = 0;
};

inline DwLayout dw_layout(int c, int kernel_h, int kernel_w) {
  DwLayout L;
  L.c = c;
  L.cp = (c + kDwChannelPad - 1) / kDwChannelPad * kDwChannelPad;
  L.taps = kernel_h * kernel_w;
  L.pairs = (L.taps + 1) / 2;
  const std::size_t cp = static_cast<std::size_t>(L.cp);
  L.bias = 0;
  L.mult = L.bias + dw_round64(cp * sizeof(int32_t));
  L.pad_row = L.mult + dw_round64(cp * sizeof(float));
  L.weights = L.pad_row + dw_round64(cp);
  L.bytes = L.weights + dw_round64(static_cast<std::size_t>(L.pairs) * cp * 2 * sizeof(int16_t));
  return L;
}

inline std::size_t dw_packed_bytes(const ConvShape& s) { return dw_layout(s.in_c, s.kernel_h, s.kernel_w).bytes; }

inline void dw_pack(const ConvShape& s, const ConvParams& p, void* dst) {
  const DwLayout L = dw_layout(s.in_c, s.kernel_h, s.kernel_w);
  auto* base = static_cast<unsigned char*>(dst);
  std::memset(base, 0, L.bytes);
  auto* bias = reinterpret_cast<int32_t*>(base + L.bias);
  auto* mult = reinterpret_cast<float*>(base + L.mult);
  auto* pad_row = reinterpret_cast<int8_t*>(base + L.pad_row);
  auto* w = reinterpret_cast<int16_t*>(base + L.weights);
  const int8_t zp = static_cast<int8_t>(s.in_zero_point);
  for (int c = 0; c < L.cp; ++c) {
    mult[c] = 1.0f;
    pad_row[c] = zp;
  }
  for (int c = 0; c < L.c; ++c) {
    const int8_t* wc = p.weights + static_cast<std::size_t>(c) * L.taps;
    int32_t sum_w = 0;  // |sum| <= 127 * 961
    for (int t = 0; t < L.taps; ++t) {
      sum_w += wc[t];
      w[(static_cast<std::size_t>(t / 2) * L.cp + c) * 2 + t % 2] = wc[t];
    }
    bias[c] = p.bias[c] - s.in_zero_point * sum_w;
    mult[c] = p.requant[c].multiplier;
  }
}

// ---- Byte layout for the unsigned-by-signed byte dot product (VPDPBUSD, AVX-512 VNNI) ----
//
// The input is made unsigned per byte (u = q ^ 0x80 = q + 128) and the extra 128 * sum_t w_t joins
// the fold: acc = (bias - (z_in + 128) * sum_t w_t) + sum_t u_t * w_t (the pad row, z_in, becomes
// z_in + 128 and still cancels its share). The two taps of a pair are interleaved byte by byte within
// each 128-bit lane (PUNPCKLBW / PUNPCKHBW), so a dword of the low (high) interleave holds channels
// 2i and 2i + 1 (8 + 2i and 9 + 2i) of the lane's 16, both taps each: VPDPBUSD with weight bytes
// (w0, w1, 0, 0) sums the even channel, (0, 0, w0, w1) the odd one. Hence four accumulators:
//     a = 2 * h + r:   channel 16 g + 8 h + 2 i + r  in dword i of lane g   (h, r in {0, 1}, i < 4)
// with no cross-lane shuffle per tap. Blob, sections 64-byte aligned, Cp = C rounded up to 64 (the
// widest block, a zmm of bytes) so every full-width load of a block stays inside the blob:
//     int32  bias[4][Cp / 4]      bias[a][4 g + i] = bias[c] - (z_in + 128) * sum_t w[c][t]
//     float  multiplier[4][Cp / 4]  (1 in the padding)
//     int8   pad_row[Cp]          z_in
//     int8   weights[P][4][Cp]    weights[p][a][16 g + 4 i + 2 r' + k] = (r' == r) ? w[c][2p + k] : 0
// |int32| stays below 2^31: |bias| <= 2^30 and each other term is below 255 * 127 * 961 < 2^25.
constexpr int kDwBytePad = 64;

struct DwByteLayout {
  int c = 0, cp = 0, taps = 0, pairs = 0;
  std::size_t bias = 0, mult = 0, pad_row = 0, weights = 0, bytes = 0;
};

inline DwByteLayout dw_byte_layout(int c, int kernel_h, int kernel_w) {
  DwByteLayout L;
  L.c = c;
  L.cp = (c + kDwBytePad - 1) / kDwBytePad * kDwBytePad;
  L.taps = kernel_h * kernel_w;
  L.pairs = (L.taps + 1) / 2;
  const std::size_t cp = static_cast<std::size_t>(L.cp);
  L.bias = 0;
  L.mult = L.bias + dw_round64(cp * sizeof(int32_t));
  L.pad_row = L.mult + dw_round64(cp * sizeof(float));
  L.weights = L.pad_row + dw_round64(cp);
  L.bytes = L.weights + dw_round64(static_cast<std::size_t>(L.pairs) * 4 * cp);
  return L;
}

inline std::size_t dw_byte_packed_bytes(const ConvShape& s) {
  return dw_byte_layout(s.in_c, s.kernel_h, s.kernel_w).bytes;
}

// Position of channel c in its accumulator's vector: accumulator a, index (int32 / float) j.
struct DwBytePos {
  int a, j;
};
inline DwBytePos dw_byte_pos(int c) {
  const int g = c / 16, k = c % 16, h = k / 8, i = (k % 8) / 2, r = k % 2;
  return {2 * h + r, 4 * g + i};
}

inline void dw_byte_pack(const ConvShape& s, const ConvParams& p, void* dst) {
  const DwByteLayout L = dw_byte_layout(s.in_c, s.kernel_h, s.kernel_w);
  auto* base = static_cast<unsigned char*>(dst);
  std::memset(base, 0, L.bytes);
  auto* bias = reinterpret_cast<int32_t*>(base + L.bias);
  auto* mult = reinterpret_cast<float*>(base + L.mult);
  auto* pad_row = reinterpret_cast<int8_t*>(base + L.pad_row);
  auto* w = reinterpret_cast<int8_t*>(base + L.weights);
  const std::size_t q = static_cast<std::size_t>(L.cp) / 4;
  for (int c = 0; c < L.cp; ++c) {
    mult[c] = 1.0f;
    pad_row[c] = static_cast<int8_t>(s.in_zero_point);
  }
  for (int c = 0; c < L.c; ++c) {
    const int8_t* wc = p.weights + static_cast<std::size_t>(c) * L.taps;
    const DwBytePos pos = dw_byte_pos(c);
    const int r = c % 2;
    int32_t sum_w = 0;
    for (int t = 0; t < L.taps; ++t) {
      sum_w += wc[t];
      const std::size_t at = (static_cast<std::size_t>(t / 2) * 4 + pos.a) * L.cp + (c / 16) * 16 +
                             ((c % 8) / 2) * 4 + 2 * r + t % 2;
      w[at] = wc[t];
    }
    bias[pos.a * q + pos.j] = p.bias[c] - (s.in_zero_point + 128) * sum_w;
    mult[pos.a * q + pos.j] = p.requant[c].multiplier;
  }
}

// What the store of a block needs besides the accumulators (requantize.h, in float).
struct DwRequant {
  float y_lo, y_hi;  // float(out_min - zp), float(out_max - zp)
  int32_t zp, lo, hi;
};

// Channels [c0, c) of one output pixel without SIMD, for the ISAs without lane masks (at most
// kWidth - 1 channels): the same folded sum, then the shared scalar requantisation. Tap t reads
// base + off[t] (addresses as integers, as in dw_run).
inline void dw_tail_scalar(std::intptr_t base, const std::intptr_t* off, int pairs, int cp, int c0, int c,
                           const int32_t* bias, const float* mult, const int16_t* w, const DwRequant& rq, int8_t* dst) {
  for (int ch = c0; ch < c; ++ch) {
    int32_t acc = bias[ch];
    for (int p = 0; p < pairs; ++p) {
      const int16_t* wp = w + (static_cast<std::size_t>(p) * cp + ch) * 2;
      acc += int32_t(reinterpret_cast<const int8_t*>(base + off[2 * p])[ch]) * wp[0] +
             int32_t(reinterpret_cast<const int8_t*>(base + off[2 * p + 1])[ch]) * wp[1];
    }
    dst[ch] = requantize(acc, mult[ch], rq.zp, rq.lo, rq.hi);
  }
}

// NPX output pixels, all channels. Tap t of pixel x is at base[x] + off[t] (addresses as integers:
// interior pixels use the window's first pixel and fixed offsets, border pixels base 0 and a table
// of addresses). The NPX pixels share each block's bias and weight loads.
template <class V, int NPX>
inline void dw_pixels(const std::intptr_t* base, const std::intptr_t* off, const DwLayout& L, const int32_t* bias,
                      const float* mult, const int16_t* weights, const DwRequant& rq, int8_t* const* dst) {
  constexpr int W = V::kWidth;
  const std::size_t pair_stride = static_cast<std::size_t>(L.cp) * 2;  // int16 per tap pair
  const int C = L.c;
  int c0 = 0;
  for (; c0 + W <= C; c0 += W) {
    typename V::Acc acc[NPX];
    acc[0] = V::load_bias(bias + c0);
    for (int x = 1; x < NPX; ++x) acc[x] = acc[0];
    const int16_t* w = weights + static_cast<std::size_t>(c0) * 2;
    for (int p = 0; p < L.pairs; ++p, w += pair_stride) {
      const std::intptr_t o0 = off[2 * p] + c0, o1 = off[2 * p + 1] + c0;
      for (int x = 0; x < NPX; ++x)
        acc[x] = V::mac2(acc[x], reinterpret_cast<const int8_t*>(base[x] + o0),
                         reinterpret_cast<const int8_t*>(base[x] + o1), w);
    }
    for (int x = 0; x < NPX; ++x) V::store(acc[x], mult + c0, rq, dst[x] + c0);
  }
  if (c0 < C) {
    for (int x = 0; x < NPX; ++x) {
      if constexpr (V::kMasked) {
        const int n = C - c0;
        typename V::Acc acc = V::load_bias(bias + c0);
        const int16_t* w = weights + static_cast<std::size_t>(c0) * 2;
        for (int p = 0; p < L.pairs; ++p, w += pair_stride)
          acc = V::mac2_n(acc, reinterpret_cast<const int8_t*>(base[x] + off[2 * p] + c0),
                          reinterpret_cast<const int8_t*>(base[x] + off[2 * p + 1] + c0), w, n);
        V::store_n(acc, mult + c0, rq, dst[x] + c0, n);
      } else {
        dw_tail_scalar(base[x], off, L.pairs, L.cp, c0, C, bias, mult, weights, rq, dst[x]);
      }
    }
  }
}

template <class V>
void dw_run(const ConvArgs& a) {
  const TensorI8& in = a.in;
  const MutTensorI8& out = a.out;
  const DwLayout L = dw_layout(in.c, a.kernel_h, a.kernel_w);
  const auto* base = static_cast<const unsigned char*>(a.packed);
  const auto* bias = reinterpret_cast<const int32_t*>(base + L.bias);
  const auto* mult = reinterpret_cast<const float*>(base + L.mult);
  const auto* pad_row = reinterpret_cast<const int8_t*>(base + L.pad_row);
  const auto* weights = reinterpret_cast<const int16_t*>(base + L.weights);
  const DwRequant rq = {static_cast<float>(a.out_min - out.zero_point), static_cast<float>(a.out_max - out.zero_point),
                        out.zero_point, a.out_min, a.out_max};
  const std::size_t in_row = static_cast<std::size_t>(in.w) * in.c;    // bytes per input row
  const int C = in.c;
  const int oy_end = a.oy_end < 0 ? out.h : a.oy_end;

  // Fixed-size tables on the stack (about 23 KiB: the loader keeps kernels within 31 x 31), so run()
  // never allocates. The pad row and the folded bias assume a.in.zero_point == the pack's in_zero_point.
  const int8_t* rows[kDwMaxKernel];       // input row of each ky, nullptr outside the input
  std::intptr_t offset[kDwMaxTaps + 1];  // interior pixels: tap t at the window's first pixel + offset[t]
  std::intptr_t tab[kDwMaxTaps + 1];     // border pixels: tap t's address (the pad row outside the input)
  for (int ky = 0, t = 0; ky < a.kernel_h; ++ky)
    for (int kx = 0; kx < a.kernel_w; ++kx, ++t)
      offset[t] = static_cast<std::intptr_t>(ky) * a.dilation_h * static_cast<std::intptr_t>(in_row) +
                  static_cast<std::intptr_t>(kx) * a.dilation_w * C;
  // The weight-0 partner of the last tap when taps is odd: any readable pixel.
  offset[L.taps] = offset[L.taps - 1];
  tab[L.taps] = reinterpret_cast<std::intptr_t>(pad_row);
  const int span_w = (a.kernel_w - 1) * a.dilation_w;  // first to last tap column, pixels
  const std::intptr_t step = static_cast<std::intptr_t>(a.stride_w) * C;  // the next pixel's window

  for (int oy = a.oy_begin; oy < oy_end; ++oy) {
    bool rows_inside = true;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      const int iy = oy * a.stride_h - a.pad_top + ky * a.dilation_h;
      rows[ky] = (iy >= 0 && iy < in.h) ? in.data + static_cast<std::size_t>(iy) * in_row : nullptr;
      rows_inside = rows_inside && rows[ky];
    }
    int8_t* const row_dst = out.data + static_cast<std::size_t>(oy) * out.w * out.c;
    const auto interior = [&](int ox) {
      const int ix0 = ox * a.stride_w - a.pad_left;
      return rows_inside && ix0 >= 0 && ix0 + span_w < in.w;
    };
    for (int ox = 0; ox < out.w;) {
      int8_t* dst[2] = {row_dst + static_cast<std::size_t>(ox) * out.c, nullptr};
      const int ix0 = ox * a.stride_w - a.pad_left;
      if (interior(ox)) {
        const std::intptr_t first = reinterpret_cast<std::intptr_t>(rows[0] + static_cast<std::ptrdiff_t>(ix0) * C);
        if (ox + 1 < out.w && interior(ox + 1)) {
          const std::intptr_t two[2] = {first, first + step};
          dst[1] = dst[0] + out.c;
          dw_pixels<V, 2>(two, offset, L, bias, mult, weights, rq, dst);
          ox += 2;
        } else {
          dw_pixels<V, 1>(&first, offset, L, bias, mult, weights, rq, dst);
          ox += 1;
        }
      } else {
        for (int ky = 0, t = 0; ky < a.kernel_h; ++ky) {
          for (int kx = 0, ix = ix0; kx < a.kernel_w; ++kx, ++t, ix += a.dilation_w) {
            tab[t] = reinterpret_cast<std::intptr_t>(
                (rows[ky] && ix >= 0 && ix < in.w) ? rows[ky] + static_cast<std::size_t>(ix) * C : pad_row);
          }
        }
        const std::intptr_t zero = 0;
        dw_pixels<V, 1>(&zero, tab, L, bias, mult, weights, rq, dst);
        ox += 1;
      }
    }
  }
}

}  // namespace
}  // namespace ef::nn
