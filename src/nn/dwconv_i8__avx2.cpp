// dwconv_i8 for AVX2: 8 channels per block in one ymm accumulator. Per tap pair, the 8 input bytes of
// both taps are interleaved (PUNPCKLBW), sign-extended to 8 int16 pairs in a ymm (VPMOVSXBW) and
// multiplied-and-summed with the interleaved weights (VPMADDWD); requantisation in float as
// nn/requantize.h. Blocks of 8 rather than 16 keep the scalar tail below 8 channels at no cost per
// channel in the loop (the 16-wide form needs two of each instruction anyway).
#include <immintrin.h>

#include "nn/dwconv_i8_simd.h"

namespace ef::nn {

namespace {
struct Avx2 {
  static constexpr int kWidth = 8;
  static constexpr bool kMasked = false;
  using Acc = __m256i;
  static Acc load_bias(const int32_t* b) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b)); }
  static Acc mac2(Acc acc, const int8_t* x0, const int8_t* x1, const int16_t* w) {
    const __m128i pairs = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(x0)),
                                            _mm_loadl_epi64(reinterpret_cast<const __m128i*>(x1)));
    const __m256i prod =
        _mm256_madd_epi16(_mm256_cvtepi8_epi16(pairs), _mm256_loadu_si256(reinterpret_cast<const __m256i*>(w)));
    return _mm256_add_epi32(acc, prod);
  }
  static void store(Acc acc, const float* m, const DwRequant& rq, int8_t* dst) {
    __m256 y = _mm256_mul_ps(_mm256_cvtepi32_ps(acc), _mm256_loadu_ps(m));
    y = _mm256_min_ps(_mm256_max_ps(y, _mm256_set1_ps(rq.y_lo)), _mm256_set1_ps(rq.y_hi));
    const __m256i q = _mm256_add_epi32(_mm256_cvtps_epi32(y), _mm256_set1_epi32(rq.zp));
    // In range after the clamp, so the saturating packs only narrow.
    const __m128i q16 = _mm_packs_epi32(_mm256_castsi256_si128(q), _mm256_extracti128_si256(q, 1));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), _mm_packs_epi16(q16, q16));
  }
};

std::size_t packed_bytes(const ConvShape& shape) { return dw_packed_bytes(shape); }
void pack(const ConvShape& shape, const ConvParams& params, void* dst) { dw_pack(shape, params, dst); }
void run(const ConvArgs& a) { dw_run<Avx2>(a); }
}  // namespace

const ConvKernel dwconv_i8__avx2 = {packed_bytes, pack, run};

}  // namespace ef::nn
