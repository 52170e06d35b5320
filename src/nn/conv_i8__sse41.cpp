// conv_i8 for SSE4.1 (the x86-64 baseline): the PMADDWD tile (nn/conv_i8_pmaddwd.h) on 128-bit
// registers, panels of 4 output channels.
#include <smmintrin.h>

#include "nn/conv_i8_pmaddwd.h"

namespace ef::nn {
namespace {

struct Sse41 {
  using R = __m128i;
  static constexpr int kLanes = 4;
  static constexpr int kRegisters = 16;
  static constexpr int kWholeWindowSpareRegisters = 0;
  static void widen8(uint64_t bytes, int16_t* dst) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm_cvtepi8_epi16(_mm_cvtsi64_si128(static_cast<long long>(bytes))));
  }
  static R broadcast_pair(const int16_t* p) {
    int32_t pair;
    std::memcpy(&pair, p, 4);
    return _mm_set1_epi32(pair);
  }
  static R load_i16(const int16_t* w) { return _mm_load_si128(reinterpret_cast<const __m128i*>(w)); }
  static R madd_add(R acc, R x, R w) { return _mm_add_epi32(acc, _mm_madd_epi16(x, w)); }
  static R load_i32(const int32_t* p) { return _mm_load_si128(reinterpret_cast<const __m128i*>(p)); }
  // The NV panels of one pixel, one after another; `valid` (>= 1) channels from dst on.
  template <int NV>
  static void store_requantized(const R (&acc)[NV], const float* mult, int32_t zp, int32_t lo, int32_t hi, int8_t* dst,
                                int valid) {
    for (int v = 0; v < NV && 4 * v < valid; ++v)
      store_panel(acc[v], mult + 4 * v, zp, lo, hi, dst + 4 * v, valid - 4 * v < 4 ? valid - 4 * v : 4);
  }
  // nn/requantize.h on 4 lanes; `valid` (1..4) channels are stored.
  static void store_panel(R acc, const float* mult, int32_t zp, int32_t lo, int32_t hi, int8_t* dst, int valid) {
    __m128 f = _mm_mul_ps(_mm_cvtepi32_ps(acc), _mm_load_ps(mult));
    f = _mm_min_ps(_mm_max_ps(f, _mm_set1_ps(float(lo - zp))), _mm_set1_ps(float(hi - zp)));
    const __m128i q = _mm_add_epi32(_mm_cvtps_epi32(f), _mm_set1_epi32(zp));
    const __m128i q16 = _mm_packs_epi32(q, q);  // exact: values within [-128, 127]
    const int32_t four = _mm_cvtsi128_si32(_mm_packs_epi16(q16, q16));
    if (valid == 4) {
      std::memcpy(dst, &four, 4);
    } else {
      for (int i = 0; i < valid; ++i) dst[i] = static_cast<int8_t>(four >> (8 * i));
    }
  }
};

constexpr ConvPackLayout kLayout{4, 2, 2, 8, 0};
std::size_t packed_bytes(const ConvShape& s) { return conv_packed_bytes(kLayout, pmaddwd_packing_shape(s)); }
void pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kLayout, pmaddwd_packing_shape(s), p, dst); }
void run(const ConvArgs& a) { pmaddwd_conv_rows<Sse41>(a); }

}  // namespace

const ConvKernel conv_i8__sse41 = {packed_bytes, pack, run};

}  // namespace ef::nn
