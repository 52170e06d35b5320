// The conv_i8 tile for x86 without VNNI (SSE4.1 and AVX2), written once over a small vector traits
// class. PMADDWD multiplies int16 pairs and adds each pair into an int32 lane, so for each tap the
// tile first widens up to 64 input channels of each of its MR pixels to int16 in a stack buffer,
// then broadcasts one int16 pair at a time from there (a load, no shuffle) and multiplies it by the
// pair's weights of `lanes` output channels in each of NV panels. At the end each pixel's NV panels
// are requantised together and stored as one run of bytes (one 32-byte store for 4 AVX2 panels).
// Exact: int16 products of int8 values cannot saturate, unlike PMADDUBSW's int16 pair sums.
// Weights [tap][cin/2][lanes][2] int16 (ConvPackLayout{lanes, 2, 2, 8, 0}); raw input bytes, the
// zero point is folded into the biases by the pack.
//
// Traits V provides: type R (register), kLanes, kRegisters,
//   void widen8(uint64_t eight_bytes, int16_t* dst)  eight int8 -> eight int16 at dst
//   R broadcast_pair(const int16_t* p)               the int16 pair at p in every 32-bit lane
//   R load_i16(const int16_t* w)                     2 * kLanes int16 weights (aligned)
//   R madd_add(R acc, R x, R w)                      acc + pmaddwd(x, w)
//   R load_i32(const int32_t*)                       kLanes biases (aligned)
//   int kWholeWindowSpareRegisters                   registers the whole-window tile leaves free
//   template <int NV> void store_requantized(const R (&acc)[NV], const float* mult, zp, lo, hi,
//                                            int8_t* dst, int n)
//       requantises one pixel's NV panels and stores their first n channels (n >= NV * lanes: all)
#pragma once

#include <cstring>

#include "nn/conv_i8_simd.h"

namespace ef::nn {
namespace {

// Input channels widened per pass in the per-tap mode, and the largest window (taps x cin) packed
// as one tap (whole-window mode); the tile's stack buffer holds MR x (kWindowMax + 8) int16 then.
inline constexpr int kBlock = 64;
inline constexpr int kWindowMax = 256;

// The shape conv_pack() sees. A layer whose input channels do not fill PMADDWD's 8-channel steps
// (the 4-channel RGB-D stem: 4 of 8 lanes would multiply zeros in every tap) is packed as one tap
// of taps x cin channels when that fits the tile's buffer: the file layout [out][tap][cin] already
// is [out][taps * cin], so only the shape changes. The kernel sees packed taps == 1 with a k x k
// layer and gathers the window itself.
inline ConvShape pmaddwd_packing_shape(const ConvShape& s) {
  const int taps = s.kernel_h * s.kernel_w;
  if (taps > 1 && s.in_c % 8 != 0 && taps * s.in_c <= kWindowMax)
    return ConvShape{taps * s.in_c, s.out_c, 1, 1, s.in_zero_point};
  return s;
}

// kWholeWindow: the layer was packed by pmaddwd_packing_shape as one tap of taps x cin channels.
// Two instantiations rather than a run-time branch, so that each has one loop nest to keep its
// accumulators in registers (GCC spilled them with both nests in one function).
template <class V, bool kWholeWindow>
struct PmaddwdTile {
  // measured on AVX2: groups of at most 2 or 3 panels (6 or 4 pixels, weights in registers) beat 4
  // on no pointwise layer of the shipped model (24 to 128 channels) and lost on most
  static constexpr int kMaxPanels = 4;
  // measured: 3 + 3 panels with weights in registers beat 4 (memory operands) + 2 on AVX2
  static constexpr bool kSixPanelsAsThrees = true;
  // Registers: MR x NV accumulators, one broadcast pair and, for up to 3 panels, the NV weight
  // vectors of the pair (loaded once, used by MR pixels). With 4 panels there is no room for them:
  // the weights stay memory operands of PMADDWD (L1 hits), measured faster than 2 pixels with
  // weights in registers. The whole-window loop leaves V::kWholeWindowSpareRegisters unused (AVX2:
  // with all 16 in use GCC spilled accumulators there; 3 pixels x 3 panels beat 4 x 3 on the stem
  // by 7%).
  template <int NV>
  static constexpr bool weights_in_registers() { return NV <= 3; }
  template <int NV>
  static constexpr int pixels() {
    constexpr int spare = kWholeWindow ? V::kWholeWindowSpareRegisters : 0;
    constexpr int free = (weights_in_registers<NV>() ? V::kRegisters - 1 - NV : V::kRegisters - 2) - spare;
    return free / NV < 8 ? free / NV : 8;
  }

  // acc += the n widened input values of each pixel (wide[m][0 .. n), n even) times the weight
  // pairs starting at w[v] (2 * kLanes int16 per pair).
  template <int NV, int MR, int W>
  __attribute__((always_inline)) static void mac(typename V::R (&acc)[MR][NV], const int16_t (&wide)[MR][W], int n,
                  const int16_t* const (&w)[NV]) {
    using R = typename V::R;
    constexpr int L = V::kLanes;
    for (int k = 0; k < n; k += 2) {
      const std::size_t wo = std::size_t(k) * L;  // pair k / 2
      if constexpr (weights_in_registers<NV>()) {
        R wv[NV];
        for (int v = 0; v < NV; ++v) wv[v] = V::load_i16(w[v] + wo);
        for (int m = 0; m < MR; ++m) {
          const R x = V::broadcast_pair(wide[m] + k);
          for (int v = 0; v < NV; ++v) acc[m][v] = V::madd_add(acc[m][v], x, wv[v]);
        }
      } else {
        for (int m = 0; m < MR; ++m) {
          const R x = V::broadcast_pair(wide[m] + k);
          for (int v = 0; v < NV; ++v) acc[m][v] = V::madd_add(acc[m][v], x, V::load_i16(w[v] + wo));
        }
      }
    }
  }

  // Widens channels [c0, c0 + n) of the pixel at p (cin channels; n rounded up to 8, the values
  // past cin are zero) to dst.
  __attribute__((always_inline)) static void widen(const int8_t* p, int cin, int c0, int n, int16_t* dst) {
    for (int c = 0; c < n; c += 8) {
      uint64_t bytes;
      const int left = cin - (c0 + c);
      if (left >= 8) std::memcpy(&bytes, p + c0 + c, 8);
      else bytes = load_tail8(p + c0 + c, left > 0 ? left : 0);  // channels past cin have zero weights
      V::widen8(bytes, dst + c);
    }
  }

  // Whole-window mode: wide[m][t * cin + c] = channel c of tap t = ky * kw + kx of pixel m, then
  // zeros up to the padded K. A row of the window inside the image (dilation_w 1) is kw * cin
  // contiguous bytes, widened as one run; other rows tap by tap, outside taps reading the pad pixel.
  // A run's last 8-wide write may go up to 7 values past it: the next row's run (or the zeros
  // written last) overwrites them, and the buffer has room for them.
  template <int MR, int W>
  __attribute__((always_inline)) static void gather_window(const TileJob& j, int taps_cin, int16_t (&wide)[MR][W]) {
    const ConvArgs& a = *j.a;
    const int cin = a.in.c, kw = a.kernel_w, run = kw * cin;
    const int8_t* pad = conv_pad_pixel(j.blob);
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      const int iy = j.oy * a.stride_h - a.pad_top + ky * a.dilation_h;
      const bool row_in = iy >= 0 && iy < a.in.h;
      const int8_t* row = a.in.data + std::ptrdiff_t(iy) * a.in.w * cin;
      for (int m = 0; m < MR; ++m) {
        const int ix = (j.ox0 + m) * a.stride_w - a.pad_left;
        int16_t* dst = wide[m] + ky * run;
        const bool valid = row_in && m < j.npix;
        if (valid && a.dilation_w == 1 && ix >= 0 && ix + kw <= a.in.w) {
          widen(row + std::ptrdiff_t(ix) * cin, run, 0, (run + 7) & ~7, dst);
        } else {
          for (int kx = 0; kx < kw; ++kx) {
            const int x = ix + kx * a.dilation_w;
            widen(valid && x >= 0 && x < a.in.w ? row + std::ptrdiff_t(x) * cin : pad, cin, 0, (cin + 7) & ~7,
                  dst + kx * cin);
          }
        }
      }
    }
    static_assert(W >= kWindowMax + 8, "room for the zeros past K");
    for (int m = 0; m < MR; ++m) V::widen8(0, wide[m] + taps_cin);  // K is padded by at most 7
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
    // Per-tap mode widens kBlock channels at a time; whole-window mode the window plus the 7 values
    // a last 8-wide store may write past it.
    alignas(64) int16_t wide[MR][kWholeWindow ? kWindowMax + 8 : kBlock];
    if constexpr (kWholeWindow) {
      // Whole-window packing (pmaddwd_packing_shape): the window's taps x cin values of each pixel
      // side by side, then one pass over K = taps * cin.
      gather_window<MR>(j, h.cin, wide);  // h.cin = taps * cin here
      mac<NV, MR>(acc, wide, h.cin_pad, w);
    } else {
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
            // Written out rather than mac(): with the offset c0 folded in here GCC keeps the
            // accumulators in registers (measured: 63 against 47 GMAC/s on 3x3 32->32).
            for (int k = 0; k < n; k += 2) {
              const std::size_t wo = std::size_t(c0 + k) * L;  // pair (c0 + k) / 2
              if constexpr (weights_in_registers<NV>()) {
                R wv[NV];
                for (int v = 0; v < NV; ++v) wv[v] = V::load_i16(w[v] + wo);
                for (int m = 0; m < MR; ++m) {
                  const R x = V::broadcast_pair(wide[m] + k);
                  for (int v = 0; v < NV; ++v) acc[m][v] = V::madd_add(acc[m][v], x, wv[v]);
                }
              } else {
                for (int m = 0; m < MR; ++m) {
                  const R x = V::broadcast_pair(wide[m] + k);
                  for (int v = 0; v < NV; ++v) acc[m][v] = V::madd_add(acc[m][v], x, V::load_i16(w[v] + wo));
                }
              }
            }
          }
          for (int v = 0; v < NV; ++v) w[v] += std::size_t(h.k_steps) * 2 * L;
        }
      }
    }

    // Each pixel's NV panels are requantised and stored together (one store where the ISA can).
    const float* mult = conv_mult(j.blob) + j.panel0 * L;
    const int c0 = j.panel0 * L;
    const int valid = h.cout - c0;  // channels of this pixel from c0 on (more than NV * L: all)
    // When this call covers all the channels and they do not fill the panels (e.g. 14 of 16), a
    // pixel's full-width store may run into the pixels after it: they are stored later (this row's
    // pixels go in increasing order), so it may, as long as it stays within the row (another
    // thread may own the next row). The output tensor is this layer's alone (out.c = cout), so
    // the bytes run into are those pixels' and nothing else's. (measured: 32->14 at 60x80, +6%)
    const bool spill_ok = j.panel0 == 0 && valid < NV * L;
    const std::ptrdiff_t row_bytes = std::ptrdiff_t(a.out.w) * a.out.c;
    for (int m = 0; m < MR; ++m) {
      if (m >= j.npix) break;
      const std::ptrdiff_t at = std::ptrdiff_t(j.ox0 + m) * a.out.c + c0;
      int8_t* dst = a.out.data + std::ptrdiff_t(j.oy) * row_bytes + at;
      const int n = spill_ok && at + NV * L <= row_bytes ? NV * L : valid;
      V::template store_requantized<NV>(acc[m], mult, a.out.zero_point, a.out_min, a.out_max, dst, n);
    }
  }
};

// The run function of a PMADDWD variant: picks the tile by how the layer was packed.
template <class V>
void pmaddwd_conv_rows(const ConvArgs& a) {
  if (conv_header(a.packed).taps == 1 && a.kernel_h * a.kernel_w > 1) conv_rows<PmaddwdTile<V, true>>(a);
  else conv_rows<PmaddwdTile<V, false>>(a);
}

}  // namespace
}  // namespace ef::nn
