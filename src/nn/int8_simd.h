// Vector operations on blocks of int8 channels, per ISA, shared by the SIMD variants of clamp_i8,
// concat_i8, avgpool_i8, upsample_{nearest,bilinear}_i8 and resize_bilinear_i8. Each op writes its arithmetic once
// (in its own `<op>_simd.h`) over the operations below; each ISA file picks the block types.
//
// A *width class* holds the arithmetic on one register width (static functions):
//   R              bytes of a block; W int16 lanes of half a block; Q / F int32 / float32 lanes of a
//                  quarter of a block (so a block is 2 W, or 4 Q)
//   splat8 max8 min8                         int8 lanes
//   hweights hmix_lo hmix_hi                 w0 * a + w1 * b on int8 a, b and weights 0..16, exact
//                                            in int16 (lo: first half of the block, hi: second half)
//   splat16 mul16 add16                      int16 lanes, wrapping (the callers keep the true values
//                                            within one 16-bit range, signed or unsigned)
//   make_div div16                           unsigned floor division by a constant (bilinear_div)
//   narrow_u8_flip(lo, hi)                   16-bit lanes in [0, 255] -> bytes - 128, as int8
//   widen<k>(R)                              quarter k of the block, sign-extended to int32
//   narrow_s8(q0, q1, q2, q3)                int32 lanes -> int8 with signed saturation, in order
//   splat32 zero32 add32 sub32 splatf cvtf mulf maxf minf cvt_round   int32 / float32 lanes; cvt_round
//                                            rounds half to even (CVTPS2DQ in the default MXCSR,
//                                            NEON FCVTNS), as round_half_even_small (requantize.h)
//   lerp_weights lerp_u8<k>                  w0 * (a + 128) + w1 * (b + 128) in int32 lanes for int8 a,
//                                            b and weights 0..2048 (exact: below 2^19), quarter k of
//                                            the block in *lane order*: bytes 4k..4k+3 of every
//                                            128-bit lane (the natural order on 128-bit registers)
//   mul32 shl32<s> shr32<s>                  int32 lanes: wrapping product, shifts (shr32 logical)
//   narrow_u8_flip32(q0, q1, q2, q3)         int32 lanes in [0, 255], quarters in lane order (as
//                                            lerp_u8 makes them) -> bytes - 128, as int8, in order
// A *block type* is a width class plus `kLanes` (bytes it moves) and load(p) / store(p, R) of those
// bytes; a block narrower than its register (X8, X4) leaves the other lanes zero on load and never
// stores them. The AVX-512 masked block (XM16) carries a byte mask: it reads and writes only its
// first n bytes (masked-off bytes are never touched, so no fault and no ASan report past a buffer),
// and its methods are members (blocks are passed as objects everywhere).
//
// ChannelBlocks<Vs...>::run(op, c, C) walks channels [c, C) of one pixel (or any index range) in
// blocks, widest first, calling op.block(V{}, c) and op.scalar(c); the last partial block of a width
// overlaps the previous one when the range is at least that wide, so op must be a pure function of
// its inputs per index (true of copies and of every formula here; clamp also tolerates in place).
// MaskedBlocks (AVX-512) is the same walk with 64-byte blocks and a byte-masked block for ranges
// shorter than 16 bytes.
//
// Everything is in an anonymous namespace: each ISA file compiles its own copy with its own flags
// (the rule in kernels/variants.h). Bit-exactness: integer operations are exact; the float ones are
// single IEEE operations. No multiply is ever followed by an add, so no FMA can be formed even where
// the compiler contracts (the ef_nn target does not pass -ffp-contract=off; the avx2 / avx512 files
// get -mfma, and FMA is baseline on AArch64).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__x86_64__)
#include <immintrin.h>
#elif defined(__aarch64__)
#include <arm_neon.h>
#endif

namespace ef::nn {
namespace {

// Divisor parameters of the bilinear upsampling: floor(n / D) for D = (2f)^2 and every n the
// interpolation can produce, 0 <= n <= 255 * D + D / 2 < 2^16 when f <= 8, as
//   ((n >> a) * m) >> (16 + b)       (a 16 x 16 -> high-16 unsigned multiply, then a shift).
// D a power of two (f = 1, 2, 4, 8): a = log2(D) - 1, m = 2^15, b = 0, i.e. n >> log2(D).
// Otherwise floor(n / D) = floor(floor(n / 4) / f^2) (nested floor division) and floor(n' / f^2) is
// the multiply by m = ceil(2^(16+s) / f^2), s = floor(log2 f^2), exact for the n' that occur; the
// static_assert below checks every n for every factor.
struct BilinearDiv {
  int a, m, b;
};
inline constexpr int kBilinearSimdMaxFactor = 8;  // larger factors overflow 16-bit lanes: reference

constexpr BilinearDiv bilinear_div(int f) {
  const int d = 4 * f * f;
  if ((f & (f - 1)) == 0) {
    int log2d = 0;
    while ((1 << log2d) < d) ++log2d;
    return BilinearDiv{log2d - 1, 1 << 15, 0};
  }
  const int ff = f * f;
  int s = 0;
  while ((2 << s) <= ff) ++s;
  return BilinearDiv{2, int(((int64_t{1} << (16 + s)) + ff - 1) / ff), s};
}

constexpr bool bilinear_div_exact(int f) {
  const BilinearDiv p = bilinear_div(f);
  const int d = 4 * f * f;
  if (p.m < 1 || p.m > 65535) return false;
  for (int n = 0; n <= 255 * d + d / 2; ++n)
    if (((((n >> p.a) * int64_t{p.m}) >> 16) >> p.b) != n / d) return false;
  return true;
}
static_assert(bilinear_div_exact(1) && bilinear_div_exact(2) && bilinear_div_exact(3) && bilinear_div_exact(4) &&
                  bilinear_div_exact(5) && bilinear_div_exact(6) && bilinear_div_exact(7) && bilinear_div_exact(8),
              "bilinear 16-bit division is not exact");

// Walks channels [c, C) in blocks of Vs (widest first); see the header comment.
template <class... Vs>
struct ChannelBlocks {
  template <class Op>
  static void run(const Op& op, int c, int C) {
    for (; c < C; ++c) op.scalar(c);
  }
};
template <class V, class... Rest>
struct ChannelBlocks<V, Rest...> {
  template <class Op>
  static void run(const Op& op, int c, int C) {
    for (; c + V::kLanes <= C; c += V::kLanes) op.block(V{}, c);
    if (c == C) return;
    if (C >= V::kLanes) op.block(V{}, C - V::kLanes);
    else ChannelBlocks<Rest...>::run(op, c, C);
  }
};

#if defined(__x86_64__)

// ------------------------------------------------------------------------------- SSE4.1 (128-bit)
struct SimdX128 {
  using R = __m128i;
  using W = __m128i;
  using Q = __m128i;
  using F = __m128;
  using HW = __m128i;
  struct Div {
    __m128i a, b;  // shift counts
    W m;
  };
  static R splat8(int v) { return _mm_set1_epi8(static_cast<char>(v)); }
  static R max8(R a, R b) { return _mm_max_epi8(a, b); }
  static R min8(R a, R b) { return _mm_min_epi8(a, b); }
  // PMADDUBSW multiplies unsigned bytes (the weights, pairs w0 w1) by signed bytes (a and b
  // interleaved) and adds each pair: |w0 a + w1 b| <= 16 * 128, no saturation.
  static HW hweights(int w0, int w1) { return _mm_set1_epi16(static_cast<short>(w0 | (w1 << 8))); }
  static W hmix_lo(R a, R b, HW w) { return _mm_maddubs_epi16(w, _mm_unpacklo_epi8(a, b)); }
  static W hmix_hi(R a, R b, HW w) { return _mm_maddubs_epi16(w, _mm_unpackhi_epi8(a, b)); }
  static W splat16(int v) { return _mm_set1_epi16(static_cast<short>(v)); }
  static W mul16(W a, W b) { return _mm_mullo_epi16(a, b); }
  static W add16(W a, W b) { return _mm_add_epi16(a, b); }
  static Div make_div(const BilinearDiv& d) { return Div{_mm_cvtsi32_si128(d.a), _mm_cvtsi32_si128(d.b), splat16(d.m)}; }
  static W div16(W n, const Div& d) { return _mm_srl_epi16(_mm_mulhi_epu16(_mm_srl_epi16(n, d.a), d.m), d.b); }
  static R narrow_u8_flip(W lo, W hi) { return _mm_xor_si128(_mm_packus_epi16(lo, hi), _mm_set1_epi8(-128)); }
  template <int k>
  static Q widen(R x) { return _mm_cvtepi8_epi32(_mm_srli_si128(x, 4 * k)); }
  static R narrow_s8(Q a, Q b, Q c, Q d) { return _mm_packs_epi16(_mm_packs_epi32(a, b), _mm_packs_epi32(c, d)); }
  static Q splat32(int32_t v) { return _mm_set1_epi32(v); }
  static Q add32(Q a, Q b) { return _mm_add_epi32(a, b); }
  static Q sub32(Q a, Q b) { return _mm_sub_epi32(a, b); }
  static Q zero32() { return _mm_setzero_si128(); }
  static F splatf(float v) { return _mm_set1_ps(v); }
  static F cvtf(Q a) { return _mm_cvtepi32_ps(a); }
  static F mulf(F a, F b) { return _mm_mul_ps(a, b); }
  static F maxf(F a, F b) { return _mm_max_ps(a, b); }
  static F minf(F a, F b) { return _mm_min_ps(a, b); }
  static Q cvt_round(F a) { return _mm_cvtps_epi32(a); }
  // The weight pair (w0, w1) as int16 in every int32 lane; lerp_u8: the flipped bytes (q + 128,
  // unsigned) interleaved a, b and zero-extended to int16 pairs, then PMADDWD (|w| <= 2048 and
  // u <= 255 are within int16; the sum is below 2^20).
  using LW = __m128i;
  static LW lerp_weights(int w0, int w1) { return _mm_set1_epi32(static_cast<int>(uint32_t(w0) | uint32_t(w1) << 16)); }
  template <int k>
  static Q lerp_u8(R a, R b, LW w) {
    const __m128i flip = _mm_set1_epi8(-128), zero = _mm_setzero_si128();
    const __m128i au = _mm_xor_si128(a, flip), bu = _mm_xor_si128(b, flip);
    const __m128i ab = k < 2 ? _mm_unpacklo_epi8(au, bu) : _mm_unpackhi_epi8(au, bu);
    return _mm_madd_epi16(k % 2 ? _mm_unpackhi_epi8(ab, zero) : _mm_unpacklo_epi8(ab, zero), w);
  }
  static Q mul32(Q a, Q b) { return _mm_mullo_epi32(a, b); }
  template <int s>
  static Q shl32(Q a) { return _mm_slli_epi32(a, s); }
  template <int s>
  static Q shr32(Q a) { return _mm_srli_epi32(a, s); }
  static R narrow_u8_flip32(Q a, Q b, Q c, Q d) {
    return _mm_xor_si128(_mm_packus_epi16(_mm_packus_epi32(a, b), _mm_packus_epi32(c, d)), _mm_set1_epi8(-128));
  }
};

struct X16 : SimdX128 {
  static constexpr int kLanes = 16;
  static R load(const int8_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
  static void store(int8_t* p, R v) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), v); }
};
struct X8 : SimdX128 {
  static constexpr int kLanes = 8;
  static R load(const int8_t* p) { return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)); }
  static void store(int8_t* p, R v) { _mm_storel_epi64(reinterpret_cast<__m128i*>(p), v); }
};
struct X4 : SimdX128 {
  static constexpr int kLanes = 4;
  static R load(const int8_t* p) {
    int32_t v;
    std::memcpy(&v, p, 4);
    return _mm_cvtsi32_si128(v);
  }
  static void store(int8_t* p, R v) {
    const int32_t x = _mm_cvtsi128_si32(v);
    std::memcpy(p, &x, 4);
  }
};

#if defined(__AVX2__)
// --------------------------------------------------------------------------------- AVX2 (256-bit)
// Unpack, PMADDUBSW and the packs work within 128-bit lanes; unpacking then packing restores the
// byte order, so only narrow_s8 (four int32 quarters, two pack levels) needs a VPERMD.
struct SimdY256 {
  using R = __m256i;
  using W = __m256i;
  using Q = __m256i;
  using F = __m256;
  using HW = __m256i;
  struct Div {
    __m128i a, b;
    W m;
  };
  static R splat8(int v) { return _mm256_set1_epi8(static_cast<char>(v)); }
  static R max8(R a, R b) { return _mm256_max_epi8(a, b); }
  static R min8(R a, R b) { return _mm256_min_epi8(a, b); }
  static HW hweights(int w0, int w1) { return _mm256_set1_epi16(static_cast<short>(w0 | (w1 << 8))); }
  static W hmix_lo(R a, R b, HW w) { return _mm256_maddubs_epi16(w, _mm256_unpacklo_epi8(a, b)); }
  static W hmix_hi(R a, R b, HW w) { return _mm256_maddubs_epi16(w, _mm256_unpackhi_epi8(a, b)); }
  static W splat16(int v) { return _mm256_set1_epi16(static_cast<short>(v)); }
  static W mul16(W a, W b) { return _mm256_mullo_epi16(a, b); }
  static W add16(W a, W b) { return _mm256_add_epi16(a, b); }
  static Div make_div(const BilinearDiv& d) { return Div{_mm_cvtsi32_si128(d.a), _mm_cvtsi32_si128(d.b), splat16(d.m)}; }
  static W div16(W n, const Div& d) { return _mm256_srl_epi16(_mm256_mulhi_epu16(_mm256_srl_epi16(n, d.a), d.m), d.b); }
  static R narrow_u8_flip(W lo, W hi) { return _mm256_xor_si256(_mm256_packus_epi16(lo, hi), _mm256_set1_epi8(-128)); }
  template <int k>
  static Q widen(R x) {
    const __m128i half = k < 2 ? _mm256_castsi256_si128(x) : _mm256_extracti128_si256(x, 1);
    return _mm256_cvtepi8_epi32(k % 2 ? _mm_srli_si128(half, 8) : half);
  }
  static R narrow_s8(Q a, Q b, Q c, Q d) {
    // Dwords after the two in-lane packs: [0..3, 8..11, 16..19, 24..27 | 4..7, 12..15, 20..23, 28..31].
    const __m256i p = _mm256_packs_epi16(_mm256_packs_epi32(a, b), _mm256_packs_epi32(c, d));
    return _mm256_permutevar8x32_epi32(p, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
  }
  static Q splat32(int32_t v) { return _mm256_set1_epi32(v); }
  static Q add32(Q a, Q b) { return _mm256_add_epi32(a, b); }
  static Q sub32(Q a, Q b) { return _mm256_sub_epi32(a, b); }
  static Q zero32() { return _mm256_setzero_si256(); }
  static F splatf(float v) { return _mm256_set1_ps(v); }
  static F cvtf(Q a) { return _mm256_cvtepi32_ps(a); }
  static F mulf(F a, F b) { return _mm256_mul_ps(a, b); }
  static F maxf(F a, F b) { return _mm256_max_ps(a, b); }
  static F minf(F a, F b) { return _mm256_min_ps(a, b); }
  static Q cvt_round(F a) { return _mm256_cvtps_epi32(a); }
  // As SimdX128; the unpacks and packs work within 128-bit lanes, so the quarters are in lane order
  // and narrow_u8_flip32's in-lane packs put the bytes back in memory order without a permute.
  using LW = __m256i;
  static LW lerp_weights(int w0, int w1) { return _mm256_set1_epi32(static_cast<int>(uint32_t(w0) | uint32_t(w1) << 16)); }
  template <int k>
  static Q lerp_u8(R a, R b, LW w) {
    const __m256i flip = _mm256_set1_epi8(-128), zero = _mm256_setzero_si256();
    const __m256i au = _mm256_xor_si256(a, flip), bu = _mm256_xor_si256(b, flip);
    const __m256i ab = k < 2 ? _mm256_unpacklo_epi8(au, bu) : _mm256_unpackhi_epi8(au, bu);
    return _mm256_madd_epi16(k % 2 ? _mm256_unpackhi_epi8(ab, zero) : _mm256_unpacklo_epi8(ab, zero), w);
  }
  static Q mul32(Q a, Q b) { return _mm256_mullo_epi32(a, b); }
  template <int s>
  static Q shl32(Q a) { return _mm256_slli_epi32(a, s); }
  template <int s>
  static Q shr32(Q a) { return _mm256_srli_epi32(a, s); }
  static R narrow_u8_flip32(Q a, Q b, Q c, Q d) {
    return _mm256_xor_si256(_mm256_packus_epi16(_mm256_packus_epi32(a, b), _mm256_packus_epi32(c, d)),
                            _mm256_set1_epi8(-128));
  }
};

struct Y32 : SimdY256 {
  static constexpr int kLanes = 32;
  static R load(const int8_t* p) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)); }
  static void store(int8_t* p, R v) { _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v); }
};
#endif  // __AVX2__

#if defined(__AVX512BW__) && defined(__AVX512VL__)
// ------------------------------------------------------------------------------ AVX-512 (512-bit)
struct SimdZ512 {
  using R = __m512i;
  using W = __m512i;
  using Q = __m512i;
  using F = __m512;
  using HW = __m512i;
  struct Div {
    __m128i a, b;
    W m;
  };
  static R splat8(int v) { return _mm512_set1_epi8(static_cast<char>(v)); }
  static R max8(R a, R b) { return _mm512_max_epi8(a, b); }
  static R min8(R a, R b) { return _mm512_min_epi8(a, b); }
  static HW hweights(int w0, int w1) { return _mm512_set1_epi16(static_cast<short>(w0 | (w1 << 8))); }
  static W hmix_lo(R a, R b, HW w) { return _mm512_maddubs_epi16(w, _mm512_unpacklo_epi8(a, b)); }
  static W hmix_hi(R a, R b, HW w) { return _mm512_maddubs_epi16(w, _mm512_unpackhi_epi8(a, b)); }
  static W splat16(int v) { return _mm512_set1_epi16(static_cast<short>(v)); }
  static W mul16(W a, W b) { return _mm512_mullo_epi16(a, b); }
  static W add16(W a, W b) { return _mm512_add_epi16(a, b); }
  static Div make_div(const BilinearDiv& d) { return Div{_mm_cvtsi32_si128(d.a), _mm_cvtsi32_si128(d.b), splat16(d.m)}; }
  static W div16(W n, const Div& d) { return _mm512_srl_epi16(_mm512_mulhi_epu16(_mm512_srl_epi16(n, d.a), d.m), d.b); }
  static R narrow_u8_flip(W lo, W hi) { return _mm512_xor_si512(_mm512_packus_epi16(lo, hi), _mm512_set1_epi8(-128)); }
  template <int k>
  static Q widen(R x) { return _mm512_cvtepi8_epi32(_mm512_extracti32x4_epi32(x, k)); }
  static R narrow_s8(Q a, Q b, Q c, Q d) {
    // After the two in-lane packs, dword j of 128-bit lane i holds elements 16 j + 4 i .. + 3: one
    // VPERMD puts dword 4 i + j at 4 j + i. (Four VPMOVSDB and three inserts cost more.)
    const __m512i p = _mm512_packs_epi16(_mm512_packs_epi32(a, b), _mm512_packs_epi32(c, d));
    return _mm512_permutexvar_epi32(_mm512_setr_epi32(0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15), p);
  }
  static Q splat32(int32_t v) { return _mm512_set1_epi32(v); }
  static Q add32(Q a, Q b) { return _mm512_add_epi32(a, b); }
  static Q sub32(Q a, Q b) { return _mm512_sub_epi32(a, b); }
  static Q zero32() { return _mm512_setzero_si512(); }
  static F splatf(float v) { return _mm512_set1_ps(v); }
  static F cvtf(Q a) { return _mm512_cvtepi32_ps(a); }
  static F mulf(F a, F b) { return _mm512_mul_ps(a, b); }
  static F maxf(F a, F b) { return _mm512_max_ps(a, b); }
  static F minf(F a, F b) { return _mm512_min_ps(a, b); }
  static Q cvt_round(F a) { return _mm512_cvtps_epi32(a); }
  // As SimdY256, in four 128-bit lanes.
  using LW = __m512i;
  static LW lerp_weights(int w0, int w1) { return _mm512_set1_epi32(static_cast<int>(uint32_t(w0) | uint32_t(w1) << 16)); }
  template <int k>
  static Q lerp_u8(R a, R b, LW w) {
    const __m512i flip = _mm512_set1_epi8(-128), zero = _mm512_setzero_si512();
    const __m512i au = _mm512_xor_si512(a, flip), bu = _mm512_xor_si512(b, flip);
    const __m512i ab = k < 2 ? _mm512_unpacklo_epi8(au, bu) : _mm512_unpackhi_epi8(au, bu);
    return _mm512_madd_epi16(k % 2 ? _mm512_unpackhi_epi8(ab, zero) : _mm512_unpacklo_epi8(ab, zero), w);
  }
  static Q mul32(Q a, Q b) { return _mm512_mullo_epi32(a, b); }
  template <int s>
  static Q shl32(Q a) { return _mm512_slli_epi32(a, s); }
  template <int s>
  static Q shr32(Q a) { return _mm512_srli_epi32(a, s); }
  static R narrow_u8_flip32(Q a, Q b, Q c, Q d) {
    return _mm512_xor_si512(_mm512_packus_epi16(_mm512_packus_epi32(a, b), _mm512_packus_epi32(c, d)),
                            _mm512_set1_epi8(-128));
  }
};

struct Z64 : SimdZ512 {
  static constexpr int kLanes = 64;
  static R load(const int8_t* p) { return _mm512_loadu_si512(p); }
  static void store(int8_t* p, R v) { _mm512_storeu_si512(p, v); }
};
// The first n bytes only (byte-masked load and store, AVX-512 BW + VL).
struct XM16 : SimdX128 {
  __mmask16 m;
  explicit XM16(__mmask16 mask) : m(mask) {}
  R load(const int8_t* p) const { return _mm_maskz_loadu_epi8(m, p); }
  void store(int8_t* p, R v) const { _mm_mask_storeu_epi8(p, m, v); }
};
// Ranges of at least 16 bytes: ChannelBlocks<Z64, Y32, X16> (64-byte blocks, then the overlapping
// tail blocks; never a scalar step). Shorter ranges (the 14 classes of the shipped network's head):
// one byte-masked xmm block. Masked accesses only where they replace several blocks: masked stores
// are slow on some AVX-512 CPUs (AMD Zen 4 among them), and the overlapping unmasked blocks measured
// faster there for 32 and 64 channels.
struct MaskedBlocks {
  template <class Op>
  static void run(const Op& op, int c, int C) {
    if (C - c >= 16) ChannelBlocks<Z64, Y32, X16>::run(op, c, C);
    else if (c < C) op.block(XM16{static_cast<__mmask16>((1u << (C - c)) - 1)}, c);
  }
};
#endif  // __AVX512BW__ && __AVX512VL__

#elif defined(__aarch64__)

// --------------------------------------------------------------------------------- NEON (128-bit)
struct SimdN128 {
  using R = int8x16_t;
  using W = int16x8_t;
  using Q = int32x4_t;
  using F = float32x4_t;
  struct HW {
    int8x8_t w0, w1;
  };
  struct Div {
    int16x8_t neg_a, neg_b;  // right shifts as negative USHL counts
    uint16x8_t m;
  };
  static R splat8(int v) { return vdupq_n_s8(static_cast<int8_t>(v)); }
  static R max8(R a, R b) { return vmaxq_s8(a, b); }
  static R min8(R a, R b) { return vminq_s8(a, b); }
  // SMULL / SMLAL on bytes: weights 0..16 fit int8, |w0 a + w1 b| <= 16 * 128.
  static HW hweights(int w0, int w1) { return HW{vdup_n_s8(static_cast<int8_t>(w0)), vdup_n_s8(static_cast<int8_t>(w1))}; }
  static W hmix_lo(R a, R b, HW w) { return vmlal_s8(vmull_s8(vget_low_s8(a), w.w0), vget_low_s8(b), w.w1); }
  static W hmix_hi(R a, R b, HW w) { return vmlal_s8(vmull_s8(vget_high_s8(a), w.w0), vget_high_s8(b), w.w1); }
  static W splat16(int v) { return vdupq_n_s16(static_cast<int16_t>(v)); }
  static W mul16(W a, W b) { return vmulq_s16(a, b); }
  static W add16(W a, W b) { return vaddq_s16(a, b); }
  static Div make_div(const BilinearDiv& d) {
    return Div{vdupq_n_s16(static_cast<int16_t>(-d.a)), vdupq_n_s16(static_cast<int16_t>(-d.b)),
               vdupq_n_u16(static_cast<uint16_t>(d.m))};
  }
  static W div16(W n, const Div& d) {
    const uint16x8_t x = vshlq_u16(vreinterpretq_u16_s16(n), d.neg_a);
    const uint32x4_t lo = vmull_u16(vget_low_u16(x), vget_low_u16(d.m));
    const uint32x4_t hi = vmull_u16(vget_high_u16(x), vget_high_u16(d.m));
    const uint16x8_t q = vcombine_u16(vshrn_n_u32(lo, 16), vshrn_n_u32(hi, 16));
    return vreinterpretq_s16_u16(vshlq_u16(q, d.neg_b));
  }
  static R narrow_u8_flip(W lo, W hi) {
    const uint8x16_t u = vcombine_u8(vmovn_u16(vreinterpretq_u16_s16(lo)), vmovn_u16(vreinterpretq_u16_s16(hi)));
    return vreinterpretq_s8_u8(veorq_u8(u, vdupq_n_u8(0x80)));
  }
  template <int k>
  static Q widen(R x) {
    const int16x8_t h = k < 2 ? vmovl_s8(vget_low_s8(x)) : vmovl_s8(vget_high_s8(x));
    return k % 2 ? vmovl_s16(vget_high_s16(h)) : vmovl_s16(vget_low_s16(h));
  }
  static R narrow_s8(Q a, Q b, Q c, Q d) {
    return vcombine_s8(vqmovn_s16(vcombine_s16(vqmovn_s32(a), vqmovn_s32(b))),
                       vqmovn_s16(vcombine_s16(vqmovn_s32(c), vqmovn_s32(d))));
  }
  static Q splat32(int32_t v) { return vdupq_n_s32(v); }
  static Q add32(Q a, Q b) { return vaddq_s32(a, b); }
  static Q sub32(Q a, Q b) { return vsubq_s32(a, b); }
  static Q zero32() { return vdupq_n_s32(0); }
  static F splatf(float v) { return vdupq_n_f32(v); }
  static F cvtf(Q a) { return vcvtq_f32_s32(a); }
  static F mulf(F a, F b) { return vmulq_f32(a, b); }
  static F maxf(F a, F b) { return vmaxq_f32(a, b); }
  static F minf(F a, F b) { return vminq_f32(a, b); }
  static Q cvt_round(F a) { return vcvtnq_s32_f32(a); }
  // UMULL / UMLAL on the flipped bytes (q + 128) widened to uint16: natural order, weights <= 2048
  // and the sum below 2^20 in uint32 lanes.
  struct LW {
    uint16x4_t w0, w1;
  };
  static LW lerp_weights(int w0, int w1) {
    return LW{vdup_n_u16(static_cast<uint16_t>(w0)), vdup_n_u16(static_cast<uint16_t>(w1))};
  }
  template <int k>
  static Q lerp_u8(R a, R b, LW w) {
    const uint8x16_t flip = vdupq_n_u8(0x80);
    const uint8x16_t au = veorq_u8(vreinterpretq_u8_s8(a), flip), bu = veorq_u8(vreinterpretq_u8_s8(b), flip);
    const uint16x8_t a16 = k < 2 ? vmovl_u8(vget_low_u8(au)) : vmovl_u8(vget_high_u8(au));
    const uint16x8_t b16 = k < 2 ? vmovl_u8(vget_low_u8(bu)) : vmovl_u8(vget_high_u8(bu));
    const uint16x4_t a4 = k % 2 ? vget_high_u16(a16) : vget_low_u16(a16);
    const uint16x4_t b4 = k % 2 ? vget_high_u16(b16) : vget_low_u16(b16);
    return vreinterpretq_s32_u32(vmlal_u16(vmull_u16(a4, w.w0), b4, w.w1));
  }
  static Q mul32(Q a, Q b) { return vmulq_s32(a, b); }
  template <int s>
  static Q shl32(Q a) { return vshlq_n_s32(a, s); }
  template <int s>
  static Q shr32(Q a) { return vreinterpretq_s32_u32(vshrq_n_u32(vreinterpretq_u32_s32(a), s)); }
  static R narrow_u8_flip32(Q a, Q b, Q c, Q d) {
    const uint16x8_t lo = vcombine_u16(vmovn_u32(vreinterpretq_u32_s32(a)), vmovn_u32(vreinterpretq_u32_s32(b)));
    const uint16x8_t hi = vcombine_u16(vmovn_u32(vreinterpretq_u32_s32(c)), vmovn_u32(vreinterpretq_u32_s32(d)));
    return vreinterpretq_s8_u8(veorq_u8(vcombine_u8(vmovn_u16(lo), vmovn_u16(hi)), vdupq_n_u8(0x80)));
  }
};

struct N16 : SimdN128 {
  static constexpr int kLanes = 16;
  static R load(const int8_t* p) { return vld1q_s8(p); }
  static void store(int8_t* p, R v) { vst1q_s8(p, v); }
};
struct N8 : SimdN128 {
  static constexpr int kLanes = 8;
  static R load(const int8_t* p) { return vcombine_s8(vld1_s8(p), vdup_n_s8(0)); }
  static void store(int8_t* p, R v) { vst1_s8(p, vget_low_s8(v)); }
};

#endif

}  // namespace
}  // namespace ef::nn
