// maxpool_i8 at the AVX-512 level (needs F and BW only; named __avx512vnni, see kernels/variants.h):
// NHWC, vectorised over channels, 64 per VPMAXSB zmm; the last C mod 64 channels with byte-masked
// loads and a byte-masked store, so nothing is read or written past a pixel's channels. The window
// of each output pixel is clipped to the input once (padding positions are skipped, so padding never
// wins; an empty window gives -128 as in the reference).
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"

#include <immintrin.h>

#include "nn/eltwise_kernels.h"
#include "nn/maxpool_i8_simd.h"

namespace ef::nn {
namespace {

struct Z64 {
  using R = __m512i;
  static R lowest() { return _mm512_set1_epi8(-128); }
  static R load(const int8_t* p) { return _mm512_loadu_si512(p); }
  static R max(R a, R b) { return _mm512_max_epi8(a, b); }
  static void store(int8_t* p, R v) { _mm512_storeu_si512(p, v); }
};

// Whole 64-channel blocks, then the last C mod 64 channels under a byte mask.
struct MaskedChannels {
  static void run(const Window& win, int c, int C, int8_t* dst) {
    for (; c + 64 <= C; c += 64) window_max<Z64>(win, c, dst);
    if (c == C) return;
    const __mmask64 m = (__mmask64{1} << (C - c)) - 1;
    __m512i acc = _mm512_set1_epi8(-128);
    for (int y = 0; y < win.ny; ++y) {
      const int8_t* p = win.src + y * win.row + c;
      for (int x = 0; x < win.nx; ++x, p += win.px) acc = _mm512_mask_max_epi8(acc, m, acc, _mm512_maskz_loadu_epi8(m, p));
    }
    _mm512_mask_storeu_epi8(dst + c, m, acc);
  }
};

}  // namespace

void maxpool_i8__avx512vnni(const PoolArgs& a) { maxpool_rows<MaskedChannels>(a); }

}  // namespace ef::nn
