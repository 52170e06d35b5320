// dwconv_i8 at the AVX-512 level: 16 channels per block in one zmm accumulator, the last C mod 16
// channels with lane masks (AVX-512 BW/VL byte-masked loads and a masked narrowing store), so no
// scalar tail. Per tap pair, the 16 input bytes of both taps are interleaved (PUNPCKLBW / PUNPCKHBW),
// sign-extended to 16 int16 pairs (VPMOVSXBW) and multiplied-and-accumulated with the interleaved
// weights by VPDPWSSD (AVX-512 VNNI, the level this file is named for); requantisation in float as
// nn/requantize.h, narrowed by VPMOVSDB (saturating; values are already in range).
#include <immintrin.h>

#include "nn/dwconv_i8_simd.h"

namespace ef::nn {

namespace {
struct Avx512 {
  static constexpr int kWidth = 16;
  static constexpr bool kMasked = true;
  using Acc = __m512i;
  static __mmask16 first(int n) { return static_cast<__mmask16>((1u << n) - 1u); }
  static Acc load_bias(const int32_t* b) { return _mm512_loadu_si512(b); }
  static Acc mac_pairs(Acc acc, __m128i a, __m128i b, const int16_t* w) {
    const __m256i pairs = _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_unpacklo_epi8(a, b)),
                                                  _mm_unpackhi_epi8(a, b), 1);
    return _mm512_dpwssd_epi32(acc, _mm512_cvtepi8_epi16(pairs), _mm512_loadu_si512(w));
  }
  static Acc mac2(Acc acc, const int8_t* x0, const int8_t* x1, const int16_t* w) {
    return mac_pairs(acc, _mm_loadu_si128(reinterpret_cast<const __m128i*>(x0)),
                     _mm_loadu_si128(reinterpret_cast<const __m128i*>(x1)), w);
  }
  static Acc mac2_n(Acc acc, const int8_t* x0, const int8_t* x1, const int16_t* w, int n) {
    const __mmask16 m = first(n);
    return mac_pairs(acc, _mm_maskz_loadu_epi8(m, x0), _mm_maskz_loadu_epi8(m, x1), w);
  }
  // GCC 12 warns (-Wmaybe-uninitialized) about the unmasked forms of several intrinsics, which merge
  // into _mm512_undefined_*(); the maskz forms with every lane set are the same instructions.
  static constexpr __mmask16 kAll = static_cast<__mmask16>(0xFFFF);
  static __m512i requant(Acc acc, const float* m, const DwRequant& rq) {
    __m512 y = _mm512_mul_ps(_mm512_maskz_cvtepi32_ps(kAll, acc), _mm512_loadu_ps(m));
    y = _mm512_maskz_min_ps(kAll, _mm512_maskz_max_ps(kAll, y, _mm512_set1_ps(rq.y_lo)), _mm512_set1_ps(rq.y_hi));
    return _mm512_add_epi32(_mm512_maskz_cvtps_epi32(kAll, y), _mm512_set1_epi32(rq.zp));
  }
  static void store(Acc acc, const float* m, const DwRequant& rq, int8_t* dst) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm512_maskz_cvtsepi32_epi8(kAll, requant(acc, m, rq)));
  }
  static void store_n(Acc acc, const float* m, const DwRequant& rq, int8_t* dst, int n) {
    _mm512_mask_cvtsepi32_storeu_epi8(dst, first(n), requant(acc, m, rq));
  }
};

std::size_t packed_bytes(const ConvShape& shape) { return dw_packed_bytes(shape); }
void pack(const ConvShape& shape, const ConvParams& params, void* dst) { dw_pack(shape, params, dst); }
void run(const ConvArgs& a) { dw_run<Avx512>(a); }
}  // namespace

const ConvKernel dwconv_i8__avx512vnni = {packed_bytes, pack, run};

}  // namespace ef::nn
