// maxpool_i8 at the SSE4.1 level: NHWC, vectorised over channels, 16 per PMAXSB. The window of each
// output pixel is clipped to the input once (padding positions are skipped, so padding never wins;
// an empty window gives -128 as in the reference). Channel tails: the last 16 channels again as an
// overlapping block when C >= 16, else 8 channels in the low half (MOVQ) and the rest one at a time;
// nothing is read or written past a pixel's channels.
#include <smmintrin.h>

#include <cstddef>
#include <cstdint>

#include "nn/eltwise_kernels.h"

namespace ef::nn {

namespace {

// The window of one output pixel clipped to the input: rows [0, ny) and columns [0, nx) starting
// at `src` (padding positions are skipped, never read). ny or nx is 0 when the window lies wholly
// in the padding; then the output is -128, as in the reference.
struct Window {
  const int8_t* src;
  int ny, nx;
};

Window clip_window(const PoolArgs& a, int oy, int ox) {
  const int iy0 = oy * a.stride_h - a.pad_top, ix0 = ox * a.stride_w - a.pad_left;
  const int ky0 = iy0 < 0 ? -iy0 : 0, kx0 = ix0 < 0 ? -ix0 : 0;
  const int ky1 = a.kernel_h < a.in.h - iy0 ? a.kernel_h : a.in.h - iy0;
  const int kx1 = a.kernel_w < a.in.w - ix0 ? a.kernel_w : a.in.w - ix0;
  Window win{a.in.data, ky1 - ky0, kx1 - kx0};
  if (win.ny <= 0 || win.nx <= 0) {
    win.ny = win.nx = 0;
  } else {
    win.src += (std::ptrdiff_t(iy0 + ky0) * a.in.w + (ix0 + kx0)) * a.in.c;
  }
  return win;
}

// Channels [c0, c1) one at a time (tails narrower than the narrowest vector).
void scalar_channels(const Window& win, std::ptrdiff_t row, std::ptrdiff_t px, int c0, int c1, int8_t* dst) {
  for (int c = c0; c < c1; ++c) {
    int32_t m = -128;
    for (int y = 0; y < win.ny; ++y)
      for (int x = 0; x < win.nx; ++x) {
        const int32_t v = win.src[y * row + x * px + c];
        if (v > m) m = v;
      }
    dst[c] = static_cast<int8_t>(m);
  }
}

// Channels [c, c + lanes) of one output pixel.
void block16(const Window& win, std::ptrdiff_t row, std::ptrdiff_t px, int c, int8_t* dst) {
  __m128i acc = _mm_set1_epi8(-128);
  for (int y = 0; y < win.ny; ++y) {
    const int8_t* p = win.src + y * row + c;
    for (int x = 0; x < win.nx; ++x, p += px)
      acc = _mm_max_epi8(acc, _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  }
  _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + c), acc);
}

// Channels [c, c + lanes) of one output pixel.
void block8(const Window& win, std::ptrdiff_t row, std::ptrdiff_t px, int c, int8_t* dst) {
  __m128i acc = _mm_set1_epi8(-128);
  for (int y = 0; y < win.ny; ++y) {
    const int8_t* p = win.src + y * row + c;
    for (int x = 0; x < win.nx; ++x, p += px)
      acc = _mm_max_epi8(acc, _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
  }
  _mm_storel_epi64(reinterpret_cast<__m128i*>(dst + c), acc);
}

}  // namespace

void maxpool_i8__sse41(const PoolArgs& a) {
  const int C = a.out.c;
  const std::ptrdiff_t px = a.in.c, row = std::ptrdiff_t(a.in.w) * a.in.c;
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox) {
      const Window win = clip_window(a, oy, ox);
      int8_t* dst = a.out.data + (std::ptrdiff_t(oy) * a.out.w + ox) * C;
      int c = 0;
      for (; c + 16 <= C; c += 16) block16(win, row, px, c, dst);
      if (c < C) {
        if (C >= 16) {
          block16(win, row, px, C - 16, dst);
        } else {
          if (c + 8 <= C) { block8(win, row, px, c, dst); c += 8; }
          scalar_channels(win, row, px, c, C, dst);
        }
      }
    }
}

}  // namespace ef::nn
