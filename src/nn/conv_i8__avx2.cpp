// conv_i8 for AVX2: the PMADDWD tile (nn/conv_i8_pmaddwd.h) on 256-bit registers, panels of 8
// output channels.
#include <immintrin.h>

#include "nn/conv_i8_pmaddwd.h"

namespace ef::nn {
namespace {

struct Avx2 {
  using R = __m256i;
  static constexpr int kLanes = 8;
  static constexpr int kRegisters = 16;
  static constexpr int kWholeWindowSpareRegisters = 1;  // see PmaddwdTile::pixels
  static void widen8(uint64_t bytes, int16_t* dst) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm_cvtepi8_epi16(_mm_cvtsi64_si128(static_cast<long long>(bytes))));
  }
  static R broadcast_pair(const int16_t* p) {
    int32_t pair;
    std::memcpy(&pair, p, 4);
    return _mm256_set1_epi32(pair);
  }
  static R load_i16(const int16_t* w) { return _mm256_load_si256(reinterpret_cast<const __m256i*>(w)); }
  static R madd_add(R acc, R x, R w) { return _mm256_add_epi32(acc, _mm256_madd_epi16(x, w)); }
  static R load_i32(const int32_t* p) { return _mm256_load_si256(reinterpret_cast<const __m256i*>(p)); }
  // nn/requantize.h on the NV panels (8 channels each) of one pixel, stored as one run of bytes;
  // `valid` (>= 1) channels from dst on belong to the pixel (8 * NV or more: all of them).
  // The zero point is added in int16 after the first pack: the rounded values are within
  // [lo - zp, hi - zp], so q + zp is within [-128, 127] and neither pack saturates.
  template <int NV>
  __attribute__((always_inline)) static void store_requantized(const R (&acc)[NV], const float* mult, int32_t zp,
                                                               int32_t lo, int32_t hi, int8_t* dst, int valid) {
    const __m256 flo = _mm256_set1_ps(float(lo - zp)), fhi = _mm256_set1_ps(float(hi - zp));
    R q[NV];
    for (int v = 0; v < NV; ++v) {
      __m256 f = _mm256_mul_ps(_mm256_cvtepi32_ps(acc[v]), _mm256_load_ps(mult + 8 * v));
      q[v] = _mm256_cvtps_epi32(_mm256_min_ps(_mm256_max_ps(f, flo), fhi));
    }
    const __m256i zp16 = _mm256_set1_epi16(static_cast<int16_t>(zp));
    if constexpr (NV == 1) {
      const __m128i w = _mm_add_epi16(_mm_packs_epi32(_mm256_castsi256_si128(q[0]), _mm256_extracti128_si256(q[0], 1)),
                                      _mm256_castsi256_si128(zp16));
      const __m128i b = _mm_packs_epi16(w, w);
      if (valid >= 8) _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), b);
      else store_tail(b, dst, valid);
    } else if constexpr (NV == 2) {
      // int16 [q0 0-3, q1 0-3 | q0 4-7, q1 4-7] -> [q0 0-7 | q1 0-7]
      const __m256i w = _mm256_permute4x64_epi64(_mm256_add_epi16(_mm256_packs_epi32(q[0], q[1]), zp16), 0xD8);
      const __m128i b = _mm_packs_epi16(_mm256_castsi256_si128(w), _mm256_extracti128_si256(w, 1));
      if (valid >= 16) _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), b);
      else store_tail(b, dst, valid);
    } else {
      static_assert(NV == 3 || NV == 4, "1..4 panels");
      // bytes, per 128-bit lane: [q0, q1, q2, q3] 0-3 | [q0, q1, q2, q3] 4-7 -> q0 0-7, q1 0-7, ...
      const __m256i w01 = _mm256_add_epi16(_mm256_packs_epi32(q[0], q[1]), zp16);
      const __m256i w23 = _mm256_add_epi16(_mm256_packs_epi32(q[2], q[NV == 4 ? 3 : 2]), zp16);
      const __m256i b = _mm256_permutevar8x32_epi32(_mm256_packs_epi16(w01, w23), _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
      if (valid >= 8 * NV) {
        if constexpr (NV == 4) {
          _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst), b);
        } else {
          _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm256_castsi256_si128(b));
          _mm_storel_epi64(reinterpret_cast<__m128i*>(dst + 16), _mm256_extracti128_si256(b, 1));
        }
      } else {
        if (valid >= 16) {
          _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm256_castsi256_si128(b));
          store_tail(_mm256_extracti128_si256(b, 1), dst + 16, valid - 16);
        } else {
          store_tail(_mm256_castsi256_si128(b), dst, valid);
        }
      }
    }
  }
  // The first n (0..15) bytes of b, without touching dst[n ..].
  static void store_tail(__m128i b, int8_t* dst, int n) {
    if (n & 8) {
      _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), b);
      b = _mm_srli_si128(b, 8);
      dst += 8;
    }
    uint64_t rest = static_cast<uint64_t>(_mm_cvtsi128_si64(b));
    if (n & 4) {
      const uint32_t four = static_cast<uint32_t>(rest);
      std::memcpy(dst, &four, 4);
      rest >>= 32;
      dst += 4;
    }
    if (n & 2) {
      const uint16_t two = static_cast<uint16_t>(rest);
      std::memcpy(dst, &two, 2);
      rest >>= 16;
      dst += 2;
    }
    if (n & 1) *dst = static_cast<int8_t>(rest);
  }
};

constexpr ConvPackLayout kLayout{8, 2, 2, 8, 0};
std::size_t packed_bytes(const ConvShape& s) { return conv_packed_bytes(kLayout, pmaddwd_packing_shape(s)); }
void pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kLayout, pmaddwd_packing_shape(s), p, dst); }
void run(const ConvArgs& a) { pmaddwd_conv_rows<Avx2>(a); }

}  // namespace

const ConvKernel conv_i8__avx2 = {packed_bytes, pack, run};

}  // namespace ef::nn
