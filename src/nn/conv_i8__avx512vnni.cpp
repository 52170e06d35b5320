// conv_i8 for AVX-512 VNNI: VPDPBUSD multiplies 4 unsigned input bytes by 4 signed weights and adds
// the 4 products into each int32 lane: 64 multiply-adds per instruction. The input bytes are made
// unsigned by flipping their top bit (q + 128); the pack folds (z + 128) * sum(w) into the biases.
// Panels of 16 output channels (one zmm of accumulators); layout [tap][cin/4][16][4] int8.
// GCC 12's AVX-512 headers pass _mm512_undefined_ps() as the unused merge source of unmasked
// intrinsics, which -Werror=uninitialized reports as maybe-uninitialized (GCC PR 105593).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>

#include <cstring>

#include "nn/conv_i8_simd.h"

namespace ef::nn {
namespace {

constexpr ConvPackLayout kLayout{16, 4, 1, 4, 128};

struct Avx512Tile {
  static constexpr int kMaxPanels = 4;
  // measured: 4 + 2 panels beat 3 + 3 for 96 channels
  static constexpr bool kSixPanelsAsThrees = false;
  // Accumulators MR x NV plus NV weight registers and one broadcast within 32 zmm.
  template <int NV>
  static constexpr int pixels() { return NV == 1 ? 10 : NV == 2 ? 6 : NV == 3 ? 6 : 5; }

  template <int NV, int MR>
  static void run(const TileJob& j) {
    const ConvArgs& a = *j.a;
    const ConvPackHeader& h = conv_header(j.blob);
    const int32_t* bias = conv_bias(j.blob) + j.panel0 * 16;
    const int8_t* w[NV];
    for (int v = 0; v < NV; ++v) w[v] = reinterpret_cast<const int8_t*>(conv_panel(j.blob, j.panel0 + v));

    __m512i acc[MR][NV];
    for (int v = 0; v < NV; ++v) {
      const __m512i b = _mm512_load_si512(bias + 16 * v);
      for (int m = 0; m < MR; ++m) acc[m][v] = b;
    }
    const __m512i flip = _mm512_set1_epi32(int32_t(0x80808080u));
    const int full = h.cin / 4, tail = h.cin % 4;
    const GroupLoader& load_group = *j.groups;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      for (int kx = 0; kx < a.kernel_w; ++kx) {
        const int8_t* p[MR];
        tap_pointers<MR>(j, ky, kx, p);
        for (int s = 0; s < full; ++s) {
          __m512i wv[NV];
          for (int v = 0; v < NV; ++v) wv[v] = _mm512_load_si512(w[v] + 64 * s);
          for (int m = 0; m < MR; ++m) {
            int32_t x;
            std::memcpy(&x, p[m] + 4 * s, 4);
            const __m512i u = _mm512_xor_si512(_mm512_set1_epi32(x), flip);
            for (int v = 0; v < NV; ++v) acc[m][v] = _mm512_dpbusd_epi32(acc[m][v], u, wv[v]);
          }
        }
        if (tail) {
          __m512i wv[NV];
          for (int v = 0; v < NV; ++v) wv[v] = _mm512_load_si512(w[v] + 64 * full);
          // Bytes past cin have zero weights: whatever they hold adds nothing.
          int32_t x[MR];
          for (int m = 0; m < MR; ++m) x[m] = load_group(p[m] + 4 * full);
          for (int m = 0; m < MR; ++m) {
            const __m512i u = _mm512_xor_si512(_mm512_set1_epi32(x[m]), flip);
            for (int v = 0; v < NV; ++v) acc[m][v] = _mm512_dpbusd_epi32(acc[m][v], u, wv[v]);
          }
        }
        for (int v = 0; v < NV; ++v) w[v] += std::size_t(h.k_steps) * 64;
      }
    }

    // Requantise (nn/requantize.h): float(acc) * m, clamp to [lo - zp, hi - zp], round half even
    // (VCVTPS2DQ in the default rounding mode), + zp; store the valid channels.
    const float* mult = conv_mult(j.blob) + j.panel0 * 16;
    const int32_t zp = a.out.zero_point;
    const __m512 lo = _mm512_set1_ps(float(a.out_min - zp)), hi = _mm512_set1_ps(float(a.out_max - zp));
    const __m512i vzp = _mm512_set1_epi32(zp);
    for (int v = 0; v < NV; ++v) {
      const int c0 = (j.panel0 + v) * 16;
      const int valid = h.cout - c0 < 16 ? h.cout - c0 : 16;
      const __mmask16 mask = __mmask16((1u << valid) - 1u);
      const __m512 mv = _mm512_load_ps(mult + 16 * v);
      for (int m = 0; m < MR; ++m) {
        if (m >= j.npix) break;
        __m512 f = _mm512_mul_ps(_mm512_cvtepi32_ps(acc[m][v]), mv);
        f = _mm512_min_ps(_mm512_max_ps(f, lo), hi);
        const __m512i q = _mm512_add_epi32(_mm512_cvtps_epi32(f), vzp);
        int8_t* dst = a.out.data + (std::ptrdiff_t(j.oy) * a.out.w + j.ox0 + m) * a.out.c + c0;
        _mm512_mask_cvtepi32_storeu_epi8(dst, mask, q);  // q is within [-128, 127]: truncation is exact
      }
    }
  }
};

std::size_t packed_bytes(const ConvShape& s) { return conv_packed_bytes(kLayout, s); }
void pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kLayout, s, p, dst); }
void run(const ConvArgs& a) { conv_rows<Avx512Tile>(a); }

}  // namespace

const ConvKernel conv_i8__avx512vnni = {packed_bytes, pack, run};

}  // namespace ef::nn
