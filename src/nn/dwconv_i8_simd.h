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

// What the store of a block needs besides the accumulators (requantize.h, in float).
struct DwRequant {
  float y_lo, y_hi;  // float(out_min - zp), float(out_max - zp)
  int32_t zp, lo, hi;
};

// Channels [c0, c) of one output pixel without SIMD, for the ISAs without lane masks (at most
// kWidth - 1 channels): the same folded sum, then the shared scalar requantisation.
inline void dw_tail_scalar(const int8_t* const* tap, int pairs, int cp, int c0, int c, const int32_t* bias,
                           const float* mult, const int16_t* w, const DwRequant& rq, int8_t* dst) {
  for (int ch = c0; ch < c; ++ch) {
    int32_t acc = bias[ch];
    for (int p = 0; p < pairs; ++p) {
      const int16_t* wp = w + (static_cast<std::size_t>(p) * cp + ch) * 2;
      acc += int32_t(tap[2 * p][ch]) * wp[0] + int32_t(tap[2 * p + 1][ch]) * wp[1];
    }
    dst[ch] = requantize(acc, mult[ch], rq.zp, rq.lo, rq.hi);
  }
}

template <class V>
void dw_run(const ConvArgs& a) {
  constexpr int W = V::kWidth;
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
  const std::size_t pair_stride = static_cast<std::size_t>(L.cp) * 2;  // int16 per tap pair
  const std::size_t in_row = static_cast<std::size_t>(in.w) * in.c;    // bytes per input row
  const int C = in.c;
  const int oy_end = a.oy_end < 0 ? out.h : a.oy_end;

  // Fixed-size tables on the stack (about 15 KiB: the loader keeps kernels within 31 x 31), so run()
  // never allocates. The pad row and the folded bias assume a.in.zero_point == the pack's in_zero_point.
  const int8_t* rows[kDwMaxKernel];    // input row of each ky, nullptr outside the input
  const int8_t* tap[kDwMaxTaps + 1];  // per output pixel: pixel of each tap (pad row outside), + a dummy
  tap[L.taps] = pad_row;              // the weight-0 partner of the last tap when taps is odd
  // Interior pixels (window wholly inside the input): tap t is the window's first pixel + offset[t].
  std::ptrdiff_t offset[kDwMaxTaps];
  for (int ky = 0, t = 0; ky < a.kernel_h; ++ky)
    for (int kx = 0; kx < a.kernel_w; ++kx, ++t)
      offset[t] = static_cast<std::ptrdiff_t>(ky) * a.dilation_h * static_cast<std::ptrdiff_t>(in_row) +
                  static_cast<std::ptrdiff_t>(kx) * a.dilation_w * C;
  const int span_w = (a.kernel_w - 1) * a.dilation_w;  // first to last tap column, pixels

  for (int oy = a.oy_begin; oy < oy_end; ++oy) {
    bool rows_inside = true;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      const int iy = oy * a.stride_h - a.pad_top + ky * a.dilation_h;
      rows[ky] = (iy >= 0 && iy < in.h) ? in.data + static_cast<std::size_t>(iy) * in_row : nullptr;
      rows_inside = rows_inside && rows[ky];
    }
    int8_t* dst = out.data + static_cast<std::size_t>(oy) * out.w * out.c;
    for (int ox = 0; ox < out.w; ++ox, dst += out.c) {
      const int ix0 = ox * a.stride_w - a.pad_left;
      if (rows_inside && ix0 >= 0 && ix0 + span_w < in.w) {
        const int8_t* first = rows[0] + static_cast<std::size_t>(ix0) * C;
        for (int t = 0; t < L.taps; ++t) tap[t] = first + offset[t];
      } else {
        for (int ky = 0, t = 0; ky < a.kernel_h; ++ky) {
          for (int kx = 0, ix = ix0; kx < a.kernel_w; ++kx, ++t, ix += a.dilation_w) {
            tap[t] = (rows[ky] && ix >= 0 && ix < in.w) ? rows[ky] + static_cast<std::size_t>(ix) * C : pad_row;
          }
        }
      }
      int c0 = 0;
      for (; c0 + W <= C; c0 += W) {
        typename V::Acc acc = V::load_bias(bias + c0);
        const int16_t* w = weights + static_cast<std::size_t>(c0) * 2;
        for (int p = 0; p < L.pairs; ++p, w += pair_stride) acc = V::mac2(acc, tap[2 * p] + c0, tap[2 * p + 1] + c0, w);
        V::store(acc, mult + c0, rq, dst + c0);
      }
      if (c0 < C) {
        if constexpr (V::kMasked) {
          const int n = C - c0;
          typename V::Acc acc = V::load_bias(bias + c0);
          const int16_t* w = weights + static_cast<std::size_t>(c0) * 2;
          for (int p = 0; p < L.pairs; ++p, w += pair_stride)
            acc = V::mac2_n(acc, tap[2 * p] + c0, tap[2 * p + 1] + c0, w, n);
          V::store_n(acc, mult + c0, rq, dst + c0, n);
        } else {
          dw_tail_scalar(tap, L.pairs, L.cp, c0, C, bias, mult, weights, rq, dst);
        }
      }
    }
  }
}

}  // namespace
}  // namespace ef::nn
