// maxpool_i8 at the AVX-512 level (needs F and BW only; named __avx512vnni, see kernels/variants.h):
// NHWC, vectorised over channels, 64 per VPMAXSB zmm; the last C mod 64 channels with byte-masked
// loads and a byte-masked store, so nothing is read or written past a pixel's channels. The window
// of each output pixel is clipped to the input once (padding positions are skipped, so padding never
// wins; an empty window gives -128 as in the reference).
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"

#include <immintrin.h>

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

// Channels [c, c + lanes) of one output pixel.
void block64(const Window& win, std::ptrdiff_t row, std::ptrdiff_t px, int c, int8_t* dst) {
  __m512i acc = _mm512_set1_epi8(-128);
  for (int y = 0; y < win.ny; ++y) {
    const int8_t* p = win.src + y * row + c;
    for (int x = 0; x < win.nx; ++x, p += px)
      acc = _mm512_max_epi8(acc, _mm512_loadu_si512(p));
  }
  _mm512_storeu_si512(dst + c, acc);
}

// Channels [c, c + popcount(m)) of one output pixel, m a low-bits mask.
void block_masked(const Window& win, std::ptrdiff_t row, std::ptrdiff_t px, int c, __mmask64 m, int8_t* dst) {
  __m512i acc = _mm512_set1_epi8(-128);
  for (int y = 0; y < win.ny; ++y) {
    const int8_t* p = win.src + y * row + c;
    for (int x = 0; x < win.nx; ++x, p += px)
      acc = _mm512_mask_max_epi8(acc, m, acc, _mm512_maskz_loadu_epi8(m, p));
  }
  _mm512_mask_storeu_epi8(dst + c, m, acc);
}

}  // namespace

void maxpool_i8__avx512vnni(const PoolArgs& a) {
  const int C = a.out.c;
  const std::ptrdiff_t px = a.in.c, row = std::ptrdiff_t(a.in.w) * a.in.c;
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox) {
      const Window win = clip_window(a, oy, ox);
      int8_t* dst = a.out.data + (std::ptrdiff_t(oy) * a.out.w + ox) * C;
      int c = 0;
      for (; c + 64 <= C; c += 64) block64(win, row, px, c, dst);
      if (c < C) block_masked(win, row, px, c, (__mmask64{1} << (C - c)) - 1, dst);
    }
}

}  // namespace ef::nn
