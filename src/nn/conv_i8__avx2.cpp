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
  // nn/requantize.h on 8 lanes; `valid` (1..8) channels are stored.
  static void store_requantized(R acc, const float* mult, int32_t zp, int32_t lo, int32_t hi, int8_t* dst, int valid) {
    __m256 f = _mm256_mul_ps(_mm256_cvtepi32_ps(acc), _mm256_load_ps(mult));
    f = _mm256_min_ps(_mm256_max_ps(f, _mm256_set1_ps(float(lo - zp))), _mm256_set1_ps(float(hi - zp)));
    const __m256i q = _mm256_add_epi32(_mm256_cvtps_epi32(f), _mm256_set1_epi32(zp));
    // Values are within [-128, 127]: the saturating packs are exact.
    const __m128i q16 = _mm_packs_epi32(_mm256_castsi256_si128(q), _mm256_extracti128_si256(q, 1));
    const __m128i q8 = _mm_packs_epi16(q16, q16);
    if (valid == 8) {
      _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), q8);
    } else {
      alignas(16) int8_t tmp[16];
      _mm_store_si128(reinterpret_cast<__m128i*>(tmp), q8);
      for (int i = 0; i < valid; ++i) dst[i] = tmp[i];
    }
  }
};

constexpr ConvPackLayout kLayout{8, 2, 2, 8, 0};
std::size_t packed_bytes(const ConvShape& s) { return conv_packed_bytes(kLayout, pmaddwd_packing_shape(s)); }
void pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kLayout, pmaddwd_packing_shape(s), p, dst); }
void run(const ConvArgs& a) { pmaddwd_conv_rows<Avx2>(a); }

}  // namespace

const ConvKernel conv_i8__avx2 = {packed_bytes, pack, run};

}  // namespace ef::nn
