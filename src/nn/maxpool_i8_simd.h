// What the SIMD variants of maxpool_i8 share, written once: the window of an output pixel clipped
// to the input, the max over a window for one block of channels (over a small vector-ops class), the
// channel split into blocks and the loop over output pixels. Internal linkage (anonymous namespace):
// each ISA file compiles its own copy with its own flags (the rule in kernels/variants.h).
#pragma once

#include <cstddef>
#include <cstdint>

#include "nn/layers_ref.h"

#if defined(__x86_64__)
#include <smmintrin.h>
#endif

namespace ef::nn {
namespace {

// The window of one output pixel clipped to the input: rows [0, ny) and columns [0, nx) starting
// at `src` (padding positions are skipped, never read). ny or nx is 0 when the window lies wholly
// in the padding; then the output is -128, as in the reference.
struct Window {
  const int8_t* src;
  int ny, nx;
  std::ptrdiff_t row, px;  // bytes from one input row / pixel to the next
};

inline Window clip_window(const PoolArgs& a, int oy, int ox) {
  const int iy0 = oy * a.stride_h - a.pad_top, ix0 = ox * a.stride_w - a.pad_left;
  const int ky0 = iy0 < 0 ? -iy0 : 0, kx0 = ix0 < 0 ? -ix0 : 0;
  const int ky1 = a.kernel_h < a.in.h - iy0 ? a.kernel_h : a.in.h - iy0;
  const int kx1 = a.kernel_w < a.in.w - ix0 ? a.kernel_w : a.in.w - ix0;
  Window win{a.in.data, ky1 - ky0, kx1 - kx0, std::ptrdiff_t(a.in.w) * a.in.c, a.in.c};
  if (win.ny <= 0 || win.nx <= 0) {
    win.ny = win.nx = 0;
  } else {
    win.src += (std::ptrdiff_t(iy0 + ky0) * a.in.w + (ix0 + kx0)) * a.in.c;
  }
  return win;
}

// Channels [c, c + V::kLanes) of one output pixel. V provides R, kLanes, R lowest() (all -128),
// R load(const int8_t*), R max(R, R), void store(int8_t*, R).
template <class V>
inline void window_max(const Window& win, int c, int8_t* dst) {
  typename V::R acc = V::lowest();
  for (int y = 0; y < win.ny; ++y) {
    const int8_t* p = win.src + y * win.row + c;
    for (int x = 0; x < win.nx; ++x, p += win.px) acc = V::max(acc, V::load(p));
  }
  V::store(dst + c, acc);
}

// Channels [c, C) with block widths Vs..., widest first: whole blocks, then one last block that
// overlaps the previous ones (max is idempotent) when C is at least a block wide, else the next
// narrower width; one channel at a time below the narrowest.
template <class... Vs>
struct PoolChannels {
  static void run(const Window& win, int c, int C, int8_t* dst) {
    for (; c < C; ++c) {
      int32_t m = -128;
      for (int y = 0; y < win.ny; ++y)
        for (int x = 0; x < win.nx; ++x) {
          const int32_t v = win.src[y * win.row + x * win.px + c];
          if (v > m) m = v;
        }
      dst[c] = static_cast<int8_t>(m);
    }
  }
};
template <class V, class... Rest>
struct PoolChannels<V, Rest...> {
  static void run(const Window& win, int c, int C, int8_t* dst) {
    for (; c + V::kLanes <= C; c += V::kLanes) window_max<V>(win, c, dst);
    if (c == C) return;
    if (C >= V::kLanes) window_max<V>(win, C - V::kLanes, dst);
    else PoolChannels<Rest...>::run(win, c, C, dst);
  }
};

#if defined(__x86_64__)
// 16- and 8-channel blocks on SSE4.1 registers (the x86 baseline; the AVX2 variant's narrow tails).
struct PoolX16 {
  using R = __m128i;
  static constexpr int kLanes = 16;
  static R lowest() { return _mm_set1_epi8(-128); }
  static R load(const int8_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
  static R max(R a, R b) { return _mm_max_epi8(a, b); }
  static void store(int8_t* p, R v) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), v); }
};
struct PoolX8 : PoolX16 {
  static constexpr int kLanes = 8;
  static R load(const int8_t* p) { return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)); }
  static void store(int8_t* p, R v) { _mm_storel_epi64(reinterpret_cast<__m128i*>(p), v); }
};
#endif

// The whole layer; Channels is a PoolChannels<...> or any class with the same run().
template <class Channels>
void maxpool_rows(const PoolArgs& a) {
  const int C = a.out.c;
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox)
      Channels::run(clip_window(a, oy, ox), 0, C, a.out.data + (std::ptrdiff_t(oy) * a.out.w + ox) * C);
}

}  // namespace
}  // namespace ef::nn
