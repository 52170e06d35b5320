// The conv_i8 tile on 256-bit VPDPBUSD, written once for two encodings of the same instruction:
//   conv_i8__avxvnni                    VEX  (_mm256_dpbusd_avx_epi32, -mavxvnni): the variant
//   conv_i8_vnni256_twin__avx512vnni    EVEX (_mm256_dpbusd_epi32, -mavx512vnni -mavx512vl): its test
//                                       twin (nn/conv_i8_twins.h), which AVX-512 VNNI CPUs run
// Both compute, per int32 lane, acc + four products of an unsigned and a signed byte, wrapping: the
// same result bit for bit. Everything else here is AVX2, so the twin tests the variant's code; the
// VEX file must never see an AVX-512 intrinsic (it runs on CPUs without AVX-512).
//
// As conv_i8__avx512vnni, with 8 lanes: the input bytes are made unsigned by flipping their top bit
// (q + 128); the pack folds (z + 128) * sum(w) into the biases (nn/conv_i8_pack.h). Panels of 8
// output channels (one ymm of int32 accumulators); layout [tap][cin/4][8][4] int8.
//
// Include only from an ISA file, after <immintrin.h>; everything is in an anonymous namespace
// (kernels/variants.h). `Dot` provides
//   static __m256i dpbusd(__m256i acc, __m256i unsigned_bytes, __m256i signed_bytes);
#pragma once

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "nn/conv_i8_simd.h"

namespace ef::nn {
namespace {

constexpr ConvPackLayout kVnni256Layout{8, 4, 1, 4, 128};

std::size_t vnni256_packed_bytes(const ConvShape& s) { return conv_packed_bytes(kVnni256Layout, s); }
void vnni256_pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kVnni256Layout, s, p, dst); }

// The first n (0..7) bytes of `bytes` to dst, without touching dst[n ..].
inline void vnni256_store_tail(uint64_t bytes, int8_t* dst, int n) {
  if (n & 4) {
    const uint32_t four = static_cast<uint32_t>(bytes);
    std::memcpy(dst, &four, 4);
    bytes >>= 32;
    dst += 4;
  }
  if (n & 2) {
    const uint16_t two = static_cast<uint16_t>(bytes);
    std::memcpy(dst, &two, 2);
    bytes >>= 16;
    dst += 2;
  }
  if (n & 1) *dst = static_cast<int8_t>(bytes);
}

template <class Dot>
struct Vnni256Tile {
  // Not measured on an AVX-VNNI CPU yet (none in the lab): the register plan of the AVX2 PMADDWD
  // tile (16 ymm), which has the same shape of loop: MR x NV accumulators, the broadcast input and
  // the flip constant, and for up to 3 panels the NV weight vectors; 4 panels keep the weights as
  // memory operands of VPDPBUSD; six panels go as 3 + 3.
  static constexpr int kMaxPanels = 4;
  static constexpr bool kSixPanelsAsThrees = true;
  template <int NV>
  static constexpr bool weights_in_registers() { return NV <= 3; }
  template <int NV>
  static constexpr int pixels() {
    constexpr int free = weights_in_registers<NV>() ? 16 - 2 - NV : 16 - 2;
    return free / NV < 8 ? free / NV : 8;
  }

  // acc += the 4 input bytes at p[m] (flipped to unsigned) times the 8 x 4 weights at w[v] + off.
  template <int NV, int MR>
  __attribute__((always_inline)) static void step(__m256i (&acc)[MR][NV], const int32_t (&x)[MR],
                                                  const int8_t* const (&w)[NV], std::size_t off) {
    const __m256i flip = _mm256_set1_epi32(int32_t(0x80808080u));
    if constexpr (weights_in_registers<NV>()) {
      __m256i wv[NV];
      for (int v = 0; v < NV; ++v) wv[v] = _mm256_load_si256(reinterpret_cast<const __m256i*>(w[v] + off));
      for (int m = 0; m < MR; ++m) {
        const __m256i u = _mm256_xor_si256(_mm256_set1_epi32(x[m]), flip);
        for (int v = 0; v < NV; ++v) acc[m][v] = Dot::dpbusd(acc[m][v], u, wv[v]);
      }
    } else {
      for (int m = 0; m < MR; ++m) {
        const __m256i u = _mm256_xor_si256(_mm256_set1_epi32(x[m]), flip);
        for (int v = 0; v < NV; ++v)
          acc[m][v] = Dot::dpbusd(acc[m][v], u, _mm256_load_si256(reinterpret_cast<const __m256i*>(w[v] + off)));
      }
    }
  }

  template <int NV, int MR>
  static void run(const TileJob& j) {
    const ConvArgs& a = *j.a;
    const ConvPackHeader& h = conv_header(j.blob);
    const int32_t* bias = conv_bias(j.blob) + j.panel0 * 8;
    const int8_t* w[NV];
    for (int v = 0; v < NV; ++v) w[v] = reinterpret_cast<const int8_t*>(conv_panel(j.blob, j.panel0 + v));

    __m256i acc[MR][NV];
    for (int v = 0; v < NV; ++v) {
      const __m256i b = _mm256_load_si256(reinterpret_cast<const __m256i*>(bias + 8 * v));
      for (int m = 0; m < MR; ++m) acc[m][v] = b;
    }
    const int full = h.cin / 4, tail = h.cin % 4;
    const GroupLoader& load_group = *j.groups;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      for (int kx = 0; kx < a.kernel_w; ++kx) {
        const int8_t* p[MR];
        tap_pointers<MR>(j, ky, kx, p);
        int32_t x[MR];
        for (int s = 0; s < full; ++s) {
          for (int m = 0; m < MR; ++m) std::memcpy(&x[m], p[m] + 4 * s, 4);
          step<NV, MR>(acc, x, w, std::size_t(32) * s);
        }
        if (tail) {
          // Bytes past cin have zero weights: whatever they hold adds nothing.
          for (int m = 0; m < MR; ++m) x[m] = load_group(p[m] + 4 * full);
          step<NV, MR>(acc, x, w, std::size_t(32) * full);
        }
        for (int v = 0; v < NV; ++v) w[v] += std::size_t(h.k_steps) * 32;
      }
    }

    // Requantise (nn/requantize.h): float(acc) * m, clamp to [lo - zp, hi - zp], round half even
    // (VCVTPS2DQ in the default rounding mode), + zp; store the valid channels. q + zp is within
    // [-128, 127], so both packs are exact.
    const float* mult = conv_mult(j.blob) + j.panel0 * 8;
    const int32_t zp = a.out.zero_point;
    const __m256 lo = _mm256_set1_ps(float(a.out_min - zp)), hi = _mm256_set1_ps(float(a.out_max - zp));
    const __m256i vzp = _mm256_set1_epi32(zp);
    for (int v = 0; v < NV; ++v) {
      const int c0 = (j.panel0 + v) * 8;
      const int valid = h.cout - c0 < 8 ? h.cout - c0 : 8;
      const __m256 mv = _mm256_load_ps(mult + 8 * v);
      for (int m = 0; m < MR; ++m) {
        if (m >= j.npix) break;
        __m256 f = _mm256_mul_ps(_mm256_cvtepi32_ps(acc[m][v]), mv);
        f = _mm256_min_ps(_mm256_max_ps(f, lo), hi);
        const __m256i q = _mm256_add_epi32(_mm256_cvtps_epi32(f), vzp);
        const __m128i q16 = _mm_packs_epi32(_mm256_castsi256_si128(q), _mm256_extracti128_si256(q, 1));
        const __m128i q8 = _mm_packs_epi16(q16, q16);
        int8_t* dst = a.out.data + (std::ptrdiff_t(j.oy) * a.out.w + j.ox0 + m) * a.out.c + c0;
        if (valid == 8) _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), q8);
        else vnni256_store_tail(static_cast<uint64_t>(_mm_cvtsi128_si64(q8)), dst, valid);
      }
    }
  }
};

}  // namespace
}  // namespace ef::nn
