// dwconv_i8 for SSE4.1 (x86-64 baseline): 8 channels per block in two xmm accumulators. Per tap pair,
// the 8 input bytes of both taps are interleaved (PUNPCKLBW), sign-extended to int16 pairs (PMOVSXBW)
// and multiplied-and-summed with the interleaved weights (PMADDWD); requantisation in float
// (CVTDQ2PS, MULPS, MAXPS, MINPS, CVTPS2DQ: round half even in the default MXCSR mode).
#include <smmintrin.h>

#include "nn/dwconv_i8_simd.h"

namespace ef::nn {

namespace {
struct Sse41 {
  static constexpr int kWidth = 8;
  static constexpr bool kMasked = false;
  struct Acc {
    __m128i lo, hi;  // channels 0-3, 4-7
  };
  static Acc load_bias(const int32_t* b) {
    return {_mm_loadu_si128(reinterpret_cast<const __m128i*>(b)),
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + 4))};
  }
  static Acc mac2(Acc acc, const int8_t* x0, const int8_t* x1, const int16_t* w) {
    const __m128i pairs = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(x0)),
                                            _mm_loadl_epi64(reinterpret_cast<const __m128i*>(x1)));
    const __m128i lo = _mm_cvtepi8_epi16(pairs), hi = _mm_cvtepi8_epi16(_mm_unpackhi_epi64(pairs, pairs));
    acc.lo = _mm_add_epi32(acc.lo, _mm_madd_epi16(lo, _mm_loadu_si128(reinterpret_cast<const __m128i*>(w))));
    acc.hi = _mm_add_epi32(acc.hi, _mm_madd_epi16(hi, _mm_loadu_si128(reinterpret_cast<const __m128i*>(w + 8))));
    return acc;
  }
  static __m128i requant4(__m128i acc, const float* m, const DwRequant& rq) {
    __m128 y = _mm_mul_ps(_mm_cvtepi32_ps(acc), _mm_loadu_ps(m));
    y = _mm_min_ps(_mm_max_ps(y, _mm_set1_ps(rq.y_lo)), _mm_set1_ps(rq.y_hi));
    return _mm_add_epi32(_mm_cvtps_epi32(y), _mm_set1_epi32(rq.zp));
  }
  static void store(Acc acc, const float* m, const DwRequant& rq, int8_t* dst) {
    // In range after the clamp, so the saturating packs only narrow.
    const __m128i q16 = _mm_packs_epi32(requant4(acc.lo, m, rq), requant4(acc.hi, m + 4, rq));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), _mm_packs_epi16(q16, q16));
  }
};

std::size_t packed_bytes(const ConvShape& shape) { return dw_packed_bytes(shape); }
void pack(const ConvShape& shape, const ConvParams& params, void* dst) { dw_pack(shape, params, dst); }
void run(const ConvArgs& a) { dw_run<Sse41>(a); }
}  // namespace

const ConvKernel dwconv_i8__sse41 = {packed_bytes, pack, run};

}  // namespace ef::nn
