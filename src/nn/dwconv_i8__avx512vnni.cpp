// dwconv_i8 at the AVX-512 level, on the byte layout of nn/dwconv_i8_simd.h (DwByteLayout): a block is
// 64 channels (a zmm of input bytes; the last C mod 64 channels in a byte-masked zmm, or a ymm when
// at most 32 remain). Per tap pair, the input bytes of both taps are loaded, interleaved within each
// 128-bit lane (VPUNPCKLBW / VPUNPCKHBW), made unsigned (XOR 0x80, folded into the bias at pack time)
// and accumulated by four VPDPBUSD (AVX-512 VNNI) whose weights select the even / odd channel of each
// dword: two in-lane shuffles per two taps and 64 channels, none across lanes. Interior pixels go two
// at a time, sharing the weight loads, with taps at fixed offsets from the window's first pixel (no
// pointer table); border pixels use a table with the pad row outside the input. Requantisation in
// float as nn/requantize.h, then two saturating packs (values already in range) and one in-lane byte
// shuffle back to channel order, and a byte-masked store.
#include <immintrin.h>

#include "nn/dwconv_i8_simd.h"

namespace ef::nn {

namespace {

// GCC 12 warns (-Wmaybe-uninitialized) about the unmasked forms of several intrinsics, which merge
// into _mm512_undefined_*(); the maskz forms with every lane set are the same instructions.
constexpr __mmask16 kAll16 = static_cast<__mmask16>(0xFFFF);

// Channel order of a lane after the packs: bytes 0,2,4,6,1,3,5,7,8,10,12,14,9,11,13,15.
#define EF_DW_UNSHUFFLE 0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15

struct Zmm {
  using V = __m512i;
  using M = __mmask64;
  static M mask(int n) { return n >= 64 ? ~M{0} : (M{1} << n) - 1; }
  static V load(const void* p) { return _mm512_loadu_si512(p); }
  static V load_n(const void* p, M m) { return _mm512_maskz_loadu_epi8(m, p); }
  static V flip() { return _mm512_set1_epi8(static_cast<char>(0x80)); }
  static V x(V a, V b) { return _mm512_xor_si512(a, b); }
  static V lo(V a, V b) { return _mm512_unpacklo_epi8(a, b); }
  static V hi(V a, V b) { return _mm512_unpackhi_epi8(a, b); }
  static V dp(V acc, V u, V w) { return _mm512_dpbusd_epi32(acc, u, w); }
  static V requant(V acc, const float* m, const DwRequant& rq) {
    __m512 y = _mm512_mul_ps(_mm512_maskz_cvtepi32_ps(kAll16, acc), _mm512_loadu_ps(m));
    y = _mm512_maskz_min_ps(kAll16, _mm512_maskz_max_ps(kAll16, y, _mm512_set1_ps(rq.y_lo)),
                            _mm512_set1_ps(rq.y_hi));
    return _mm512_add_epi32(_mm512_maskz_cvtps_epi32(kAll16, y), _mm512_set1_epi32(rq.zp));
  }
  static V to_bytes(V q0, V q1, V q2, V q3) {
    const V b = _mm512_packs_epi16(_mm512_packs_epi32(q0, q1), _mm512_packs_epi32(q2, q3));
    return _mm512_shuffle_epi8(b, _mm512_maskz_broadcast_i32x4(kAll16, _mm_setr_epi8(EF_DW_UNSHUFFLE)));
  }
  static void store(void* d, V v) { _mm512_storeu_si512(d, v); }
  static void store_n(void* d, M m, V v) { _mm512_mask_storeu_epi8(d, m, v); }
};

struct Ymm {
  using V = __m256i;
  using M = __mmask32;
  static M mask(int n) { return n >= 32 ? ~M{0} : (M{1} << n) - 1; }
  static V load(const void* p) { return _mm256_loadu_si256(static_cast<const __m256i*>(p)); }
  static V load_n(const void* p, M m) { return _mm256_maskz_loadu_epi8(m, p); }
  static V flip() { return _mm256_set1_epi8(static_cast<char>(0x80)); }
  static V x(V a, V b) { return _mm256_xor_si256(a, b); }
  static V lo(V a, V b) { return _mm256_unpacklo_epi8(a, b); }
  static V hi(V a, V b) { return _mm256_unpackhi_epi8(a, b); }
  static V dp(V acc, V u, V w) { return _mm256_dpbusd_epi32(acc, u, w); }
  static V requant(V acc, const float* m, const DwRequant& rq) {
    __m256 y = _mm256_mul_ps(_mm256_cvtepi32_ps(acc), _mm256_loadu_ps(m));
    y = _mm256_min_ps(_mm256_max_ps(y, _mm256_set1_ps(rq.y_lo)), _mm256_set1_ps(rq.y_hi));
    return _mm256_add_epi32(_mm256_cvtps_epi32(y), _mm256_set1_epi32(rq.zp));
  }
  static V to_bytes(V q0, V q1, V q2, V q3) {
    const V b = _mm256_packs_epi16(_mm256_packs_epi32(q0, q1), _mm256_packs_epi32(q2, q3));
    return _mm256_shuffle_epi8(b, _mm256_setr_epi8(EF_DW_UNSHUFFLE, EF_DW_UNSHUFFLE));
  }
  static void store(void* d, V v) { _mm256_storeu_si256(static_cast<__m256i*>(d), v); }
  static void store_n(void* d, M m, V v) { _mm256_mask_storeu_epi8(d, m, v); }
};

// What a block needs from the blob, at its first channel c0 (a multiple of 64).
struct Blk {
  const int32_t* bias;  // accumulator a at bias + a * q
  const float* mult;    // likewise
  const int8_t* w;      // pair p, accumulator a at w + (4 p + a) * cp
  std::size_t q, cp;
  int pairs;
};

// NPX output pixels, one block of channels. Tap t of pixel x reads base[x] + off[t] + c0 (as
// addresses; off[2 * pairs - 1] is valid, with weight 0, when taps is odd). kMasked: only the first
// n channels are loaded and stored.
template <class T, int NPX, bool kMasked>
inline __attribute__((always_inline)) void dw_block(const std::intptr_t* base, const std::intptr_t* off, const Blk& b,
                                                   const DwRequant& rq, int8_t* const* dst, int n) {
  using V = typename T::V;
  const typename T::M m = T::mask(n);
  V acc[NPX][4];
  for (int a = 0; a < 4; ++a) {
    const V bv = T::load(b.bias + a * b.q);
    for (int x = 0; x < NPX; ++x) acc[x][a] = bv;
  }
  const V k80 = T::flip();
  const int8_t* w = b.w;
  for (int p = 0; p < b.pairs; ++p, w += 4 * b.cp) {
    const V w0 = T::load(w), w1 = T::load(w + b.cp), w2 = T::load(w + 2 * b.cp), w3 = T::load(w + 3 * b.cp);
    for (int x = 0; x < NPX; ++x) {
      const auto* p0 = reinterpret_cast<const int8_t*>(base[x] + off[2 * p]);
      const auto* p1 = reinterpret_cast<const int8_t*>(base[x] + off[2 * p + 1]);
      V x0, x1;
      if constexpr (kMasked) {
        x0 = T::load_n(p0, m), x1 = T::load_n(p1, m);
      } else {
        x0 = T::load(p0), x1 = T::load(p1);
      }
      const V l = T::x(T::lo(x0, x1), k80), h = T::x(T::hi(x0, x1), k80);
      acc[x][0] = T::dp(acc[x][0], l, w0);
      acc[x][1] = T::dp(acc[x][1], l, w1);
      acc[x][2] = T::dp(acc[x][2], h, w2);
      acc[x][3] = T::dp(acc[x][3], h, w3);
    }
  }
  for (int x = 0; x < NPX; ++x) {
    const V v = T::to_bytes(T::requant(acc[x][0], b.mult, rq), T::requant(acc[x][1], b.mult + b.q, rq),
                            T::requant(acc[x][2], b.mult + 2 * b.q, rq), T::requant(acc[x][3], b.mult + 3 * b.q, rq));
    if constexpr (kMasked) {
      T::store_n(dst[x], m, v);
    } else {
      T::store(dst[x], v);
    }
  }
}

// All channels of NPX pixels (dst: each pixel's first output byte).
template <int NPX>
inline __attribute__((always_inline)) void dw_byte_pixels(const std::intptr_t* base, const std::intptr_t* off,
                                                    const DwByteLayout& L, const unsigned char* blob,
                                                    const DwRequant& rq, int8_t* const* dst) {
  const std::size_t q = static_cast<std::size_t>(L.cp) / 4;
  const int C = L.c;
  int c0 = 0;
  for (; c0 + 64 <= C; c0 += 64) {
    const Blk b = {reinterpret_cast<const int32_t*>(blob + L.bias) + c0 / 4,
                   reinterpret_cast<const float*>(blob + L.mult) + c0 / 4,
                   reinterpret_cast<const int8_t*>(blob + L.weights) + c0, q, static_cast<std::size_t>(L.cp), L.pairs};
    std::intptr_t bc[NPX];
    int8_t* dc[NPX];
    for (int x = 0; x < NPX; ++x) bc[x] = base[x] + c0, dc[x] = dst[x] + c0;
    dw_block<Zmm, NPX, false>(bc, off, b, rq, dc, 64);
  }
  if (c0 < C) {
    const Blk b = {reinterpret_cast<const int32_t*>(blob + L.bias) + c0 / 4,
                   reinterpret_cast<const float*>(blob + L.mult) + c0 / 4,
                   reinterpret_cast<const int8_t*>(blob + L.weights) + c0, q, static_cast<std::size_t>(L.cp), L.pairs};
    std::intptr_t bc[NPX];
    int8_t* dc[NPX];
    for (int x = 0; x < NPX; ++x) bc[x] = base[x] + c0, dc[x] = dst[x] + c0;
    const int n = C - c0;
    if (n > 32) {
      dw_block<Zmm, NPX, true>(bc, off, b, rq, dc, n);
    } else if (n == 32) {
      dw_block<Ymm, NPX, false>(bc, off, b, rq, dc, n);
    } else {
      dw_block<Ymm, NPX, true>(bc, off, b, rq, dc, n);
    }
  }
}

void run_bytes(const ConvArgs& a) {
  const TensorI8& in = a.in;
  const MutTensorI8& out = a.out;
  const DwByteLayout L = dw_byte_layout(in.c, a.kernel_h, a.kernel_w);
  const auto* blob = static_cast<const unsigned char*>(a.packed);
  const auto* pad_row = reinterpret_cast<const int8_t*>(blob + L.pad_row);
  const DwRequant rq = {static_cast<float>(a.out_min - out.zero_point), static_cast<float>(a.out_max - out.zero_point),
                        out.zero_point, a.out_min, a.out_max};
  const std::size_t in_row = static_cast<std::size_t>(in.w) * in.c;
  const int C = in.c;
  const int oy_end = a.oy_end < 0 ? out.h : a.oy_end;

  // Stack tables (about 15 KiB each at 31 x 31), so run() never allocates. The pad row and the folded
  // bias assume a.in.zero_point == the pack's in_zero_point.
  const int8_t* rows[kDwMaxKernel];
  std::intptr_t offset[kDwMaxTaps + 1];  // interior: tap t at the window's first pixel + offset[t]
  std::intptr_t tab[kDwMaxTaps + 1];     // border: tap t's address (the pad row outside the input)
  for (int ky = 0, t = 0; ky < a.kernel_h; ++ky)
    for (int kx = 0; kx < a.kernel_w; ++kx, ++t)
      offset[t] = static_cast<std::intptr_t>(ky) * a.dilation_h * static_cast<std::intptr_t>(in_row) +
                  static_cast<std::intptr_t>(kx) * a.dilation_w * C;
  offset[L.taps] = offset[L.taps - 1];  // the weight-0 partner of the last tap when taps is odd
  tab[L.taps] = reinterpret_cast<std::intptr_t>(pad_row);
  const int span_w = (a.kernel_w - 1) * a.dilation_w;
  const std::intptr_t step = static_cast<std::intptr_t>(a.stride_w) * C;  // next pixel's window

  for (int oy = a.oy_begin; oy < oy_end; ++oy) {
    bool rows_inside = true;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      const int iy = oy * a.stride_h - a.pad_top + ky * a.dilation_h;
      rows[ky] = (iy >= 0 && iy < in.h) ? in.data + static_cast<std::size_t>(iy) * in_row : nullptr;
      rows_inside = rows_inside && rows[ky];
    }
    int8_t* const row_dst = out.data + static_cast<std::size_t>(oy) * out.w * out.c;
    const auto interior = [&](int ox) {
      const int ix0 = ox * a.stride_w - a.pad_left;
      return rows_inside && ix0 >= 0 && ix0 + span_w < in.w;
    };
    for (int ox = 0; ox < out.w;) {
      int8_t* dst[2] = {row_dst + static_cast<std::size_t>(ox) * out.c, nullptr};
      const int ix0 = ox * a.stride_w - a.pad_left;
      if (interior(ox)) {
        const std::intptr_t first = reinterpret_cast<std::intptr_t>(rows[0] + static_cast<std::ptrdiff_t>(ix0) * C);
        if (ox + 1 < out.w && interior(ox + 1)) {
          const std::intptr_t base[2] = {first, first + step};
          dst[1] = dst[0] + out.c;
          dw_byte_pixels<2>(base, offset, L, blob, rq, dst);
          ox += 2;
        } else {
          dw_byte_pixels<1>(&first, offset, L, blob, rq, dst);
          ox += 1;
        }
      } else {
        for (int ky = 0, t = 0; ky < a.kernel_h; ++ky) {
          for (int kx = 0, ix = ix0; kx < a.kernel_w; ++kx, ++t, ix += a.dilation_w) {
            tab[t] = reinterpret_cast<std::intptr_t>(
                (rows[ky] && ix >= 0 && ix < in.w) ? rows[ky] + static_cast<std::size_t>(ix) * C : pad_row);
          }
        }
        const std::intptr_t zero = 0;
        dw_byte_pixels<1>(&zero, tab, L, blob, rq, dst);
        ox += 1;
      }
    }
  }
}

std::size_t packed_bytes(const ConvShape& shape) { return dw_byte_packed_bytes(shape); }
void pack(const ConvShape& shape, const ConvParams& params, void* dst) { dw_byte_pack(shape, params, dst); }
void run(const ConvArgs& a) { run_bytes(a); }
}  // namespace

const ConvKernel dwconv_i8__avx512vnni = {packed_bytes, pack, run};

}  // namespace ef::nn
