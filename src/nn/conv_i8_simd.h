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

// The last 4-byte group of a pixel whose first n (1..3) bytes are channels, for the VPDPBUSD tiles,
// in one 4-byte load: the bytes past the n channels belong to the next pixel (or are the pad
// pixel's padding) and meet zero weights. Only a group within the input tensor's last 3 bytes would
// read past the tensor; GroupLoader reads those from a copy of the last 3 bytes followed by zeros
// (selected without a branch). The pad pixel has cin_pad = 4 * ceil(cin / 4) bytes: always in
// bounds. Made once per kernel call (TileJob::groups). Measured on the 3-channel stem, 3x3 s2
// 3->32 at 193x257: AVX-512 VNNI 217 -> 167 us, AVX-VNNI 337 -> 287 us (the three loads of
// load_tail8 per pixel and tap before). A bounds check with load_tail8 as its fallback, inline or
// called, made GCC lay out the AVX-512 tile differently: 5-16% slower on 1x1 layers without a
// channel tail.
class GroupLoader {
 public:
  explicit GroupLoader(const ConvArgs& a)
      : end_(reinterpret_cast<std::uintptr_t>(a.in.data) + std::size_t(a.in.h) * a.in.w * a.in.c) {
    const std::size_t bytes = std::size_t(a.in.h) * a.in.w * a.in.c;
    for (std::size_t k = 0; k < 3; ++k) last_[k] = bytes + k >= 3 ? a.in.data[bytes + k - 3] : 0;
  }
  int32_t operator()(const int8_t* p) const {
    const std::uintptr_t d = end_ - reinterpret_cast<std::uintptr_t>(p);  // 1..3: p is in the last 3 bytes
    const int8_t* q = d - 1 < 3 ? last_ + 3 - d : p;
    int32_t x;
    std::memcpy(&x, q, 4);
    return x;
  }

 private:
  std::uintptr_t end_;
  int8_t last_[8] = {};  // the tensor's last 3 bytes, then zeros
};

// One call of a tile kernel: output row `oy`, pixels ox0 .. ox0 + npix - 1 (npix <= MR), panels
// panel0 .. panel0 + NV - 1.
struct TileJob {
  const ConvArgs* a;
  const void* blob;
  int oy, ox0, npix, panel0;
  const GroupLoader* groups;  // made once per call of the kernel (for the VPDPBUSD tiles)
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

// The last, partial tile of a row (j.npix < MR pixels): a tile of 1, 2 or 4 pixels where that is
// smaller than MR, so that the pixels past the row's end (which read the pad pixel and are never
// stored) cost no multiply-adds. A row of one pixel (the 1 x 1 convolution after a global pool)
// otherwise did MR times the work (measured on 320->256 at 1 x 1: AVX-512 VNNI 0.9 -> 0.6 us, 0.85x
// -> 1.26-1.35x XNNPACK; AVX2 2.7 -> 1.2-1.3 us, 0.47x -> 0.98-1.03x XNNPACK capped at AVX2). Each
// pixel's sums are the same instructions in the same order whatever MR is: the bytes do not change.
// Each tile size is its own function: GCC otherwise inlined some of them into conv_rows (one 28 KB
// function on AVX-VNNI once the partial tiles were added) and the large 1x1 layers ran 7-25% slower.
template <class Tile, int NV, int MR>
__attribute__((noinline)) void run_tile(const TileJob& j) {
  Tile::template run<NV, MR>(j);
}

template <class Tile, int NV, int MR>
inline bool run_partial_tile(const TileJob& j) {
  if constexpr (MR > 1) {
    if (j.npix == 1) return run_tile<Tile, NV, 1>(j), true;
  }
  if constexpr (MR > 2) {
    if (j.npix == 2) return run_tile<Tile, NV, 2>(j), true;
  }
  if constexpr (MR > 4) {
    if (j.npix <= 4) return run_tile<Tile, NV, 4>(j), true;
  }
  return false;  // no smaller tile: the MR tile takes it
}

template <class Tile, int NV>
inline void run_panels(const TileJob& base, int npix_total, int panel0) {
  constexpr int MR = Tile::template pixels<NV>();
  TileJob j = base;
  j.panel0 = panel0;
  for (int ox = 0; ox < npix_total; ox += MR) {
    j.ox0 = ox;
    j.npix = npix_total - ox < MR ? npix_total - ox : MR;
    if (j.npix < MR && run_partial_tile<Tile, NV, MR>(j)) break;
    run_tile<Tile, NV, MR>(j);
  }
}

// Dispatches the panel groups of one output row. Panels go kMaxPanels at a time (or threes, see
// kSixPanelsAsThrees); the rest in one narrower call.
template <class Tile>
void conv_rows(const ConvArgs& a) {
  const ConvPackHeader& h = conv_header(a.packed);
  const int oy_end = a.oy_end < 0 ? a.out.h : a.oy_end;
  constexpr int kMax = Tile::kMaxPanels;
  const GroupLoader groups(a);
  static_assert(kMax >= 1 && kMax <= 4, "tile kernels are instantiated for 1..4 panels");
  for (int oy = a.oy_begin; oy < oy_end; ++oy) {
    TileJob j{&a, a.packed, oy, 0, 0, 0, &groups};
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
