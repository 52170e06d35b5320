// The loop nest shared by every SIMD conv_i8 variant, written once: output rows -> tiles of MR
// output pixels -> groups of up to NV channel panels -> the ISA's tile kernel, which accumulates
// every tap and input channel for MR x NV panels in registers, then requantises and stores.
//
// Everything here is in an anonymous namespace: each ISA file compiles its own copy with its own
// flags (the rule in kernels/variants.h).
//
// A Tile class provides:
//   static constexpr int kMaxPanels;               panels per call (NV <= kMaxPanels)
//   static constexpr bool kSixPanelsAsThrees;      group panel counts divisible by 3 (not 4) in threes
//   template <int NV> static constexpr int pixels();  MR for NV panels (register budget)
//   template <int NV, int MR> static void run(const TileJob& job);
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "nn/conv_i8_pack.h"

namespace ef::nn {
namespace {

// One call of a tile kernel: output row `oy`, pixels ox0 .. ox0 + npix - 1 (npix <= MR), panels
// panel0 .. panel0 + NV - 1.
struct TileJob {
  const ConvArgs* a;
  const void* blob;
  int oy, ox0, npix, panel0;
};

// Input pixel pointers of tap (ky, kx) for MR output pixels: the pixel's first channel, or the
// pad pixel (the zero point, cin_pad bytes) when the tap falls outside the image or the output
// pixel is past the end of the row (npix < MR; its result is never stored).
template <int MR>
inline void tap_pointers(const TileJob& j, int ky, int kx, const int8_t* p[MR]) {
  const ConvArgs& a = *j.a;
  const int8_t* pad = conv_pad_pixel(j.blob);
  const int iy = j.oy * a.stride_h - a.pad_top + ky * a.dilation_h;
  const bool row_in = iy >= 0 && iy < a.in.h;
  const int8_t* row = a.in.data + std::ptrdiff_t(iy) * a.in.w * a.in.c;
  for (int m = 0; m < MR; ++m) {
    const int ix = (j.ox0 + m) * a.stride_w - a.pad_left + kx * a.dilation_w;
    p[m] = (row_in && m < j.npix && ix >= 0 && ix < a.in.w) ? row + std::ptrdiff_t(ix) * a.in.c : pad;
  }
}

// Copies n < 8 bytes (a channel tail) into a zero-filled 8-byte word, in at most three loads
// (4, 2, 1 bytes): never reads past the n bytes that belong to the pixel.
inline uint64_t load_tail8(const int8_t* p, int n) {
  uint64_t v = 0;
  int at = 0;
  if (n & 4) {
    uint32_t four;
    std::memcpy(&four, p, 4);
    v = four;
    at = 4;
  }
  if (n & 2) {
    uint16_t two;
    std::memcpy(&two, p + at, 2);
    v |= uint64_t{two} << (8 * at);
    at += 2;
  }
  if (n & 1) v |= uint64_t{static_cast<uint8_t>(p[at])} << (8 * at);
  return v;
}

template <class Tile, int NV>
inline void run_panels(const TileJob& base, int npix_total, int panel0) {
  constexpr int MR = Tile::template pixels<NV>();
  TileJob j = base;
  j.panel0 = panel0;
  for (int ox = 0; ox < npix_total; ox += MR) {
    j.ox0 = ox;
    j.npix = npix_total - ox < MR ? npix_total - ox : MR;
    Tile::template run<NV, MR>(j);
  }
}

// Dispatches the panel groups of one output row. Panels go kMaxPanels at a time (or threes, see
// kSixPanelsAsThrees); the rest in one narrower call.
template <class Tile>
void conv_rows(const ConvArgs& a) {
  const ConvPackHeader& h = conv_header(a.packed);
  const int oy_end = a.oy_end < 0 ? a.out.h : a.oy_end;
  constexpr int kMax = Tile::kMaxPanels;
  static_assert(kMax >= 1 && kMax <= 4, "tile kernels are instantiated for 1..4 panels");
  for (int oy = a.oy_begin; oy < oy_end; ++oy) {
    TileJob j{&a, a.packed, oy, 0, 0, 0};
    int p = 0;
    // A tile may ask for six panels (48 channels on AVX2) as 3 + 3 rather than 4 + 2.
    if (Tile::kSixPanelsAsThrees && kMax == 4 && h.panels % 4 != 0 && h.panels % 3 == 0) {
      for (; p + 3 <= h.panels; p += 3) run_panels<Tile, (kMax > 3 ? 3 : 1)>(j, a.out.w, p);
    }
    for (; p + kMax <= h.panels; p += kMax) run_panels<Tile, kMax>(j, a.out.w, p);
    switch (h.panels - p) {
      case 0: break;
      case 1: run_panels<Tile, 1>(j, a.out.w, p); break;
      case 2: if constexpr (kMax > 2) run_panels<Tile, (kMax > 2 ? 2 : 1)>(j, a.out.w, p); break;
      case 3: if constexpr (kMax > 3) run_panels<Tile, (kMax > 3 ? 3 : 1)>(j, a.out.w, p); break;
      default: break;
    }
  }
}

}  // namespace
}  // namespace ef::nn
