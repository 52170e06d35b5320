// add_i8 at the AVX2 level: 32 elements per step, as add_i8__sse41 on 8-lane vectors: sign-extend
// to int32, float(a - za) * ma + float(b - zb) * mb (two VMULPS, one VADDPS, no FMA), clamp, round
// half to even (VCVTPS2DQ), add the output zero point, pack with saturation (values already in
// range) and undo the packs' in-lane order with VPERMQ. Both inputs are loaded before the store, so
// out may alias a or b. The last n mod 32 elements go through add_i8_ref on a sub-range view.
#include <immintrin.h>

#include <cstddef>

#include "nn/eltwise_kernels.h"

namespace ef::nn {

namespace {

struct Consts {
  __m256i za, zb, zo;
  __m256 ma, mb, lo, hi;
};

__m256i eighth(__m128i a8, __m128i b8, const Consts& k) {
  const __m256 ya = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_cvtepi8_epi32(a8), k.za)), k.ma);
  const __m256 yb = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_cvtepi8_epi32(b8), k.zb)), k.mb);
  __m256 y = _mm256_add_ps(ya, yb);
  y = _mm256_min_ps(_mm256_max_ps(y, k.lo), k.hi);
  return _mm256_add_epi32(_mm256_cvtps_epi32(y), k.zo);
}

}  // namespace

void add_i8__avx2(const AddArgs& a) {
  const std::size_t n = std::size_t(a.out.h) * a.out.w * a.out.c;
  Consts k;
  k.za = _mm256_set1_epi32(a.a.zero_point);
  k.zb = _mm256_set1_epi32(a.b.zero_point);
  k.zo = _mm256_set1_epi32(a.out.zero_point);
  k.ma = _mm256_set1_ps(a.rq_a.multiplier);
  k.mb = _mm256_set1_ps(a.rq_b.multiplier);
  k.lo = _mm256_set1_ps(float(a.out_min - a.out.zero_point));
  k.hi = _mm256_set1_ps(float(a.out_max - a.out.zero_point));
  const int8_t* pa = a.a.data;
  const int8_t* pb = a.b.data;
  int8_t* po = a.out.data;
  std::size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    const __m128i a0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pa + i));
    const __m128i a1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pa + i + 16));
    const __m128i b0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pb + i));
    const __m128i b1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pb + i + 16));
    const __m256i r0 = eighth(a0, b0, k);
    const __m256i r1 = eighth(_mm_srli_si128(a0, 8), _mm_srli_si128(b0, 8), k);
    const __m256i r2 = eighth(a1, b1, k);
    const __m256i r3 = eighth(_mm_srli_si128(a1, 8), _mm_srli_si128(b1, 8), k);
    // packs work per 128-bit lane: w01 = [r0 lo4, r1 lo4, r0 hi4, r1 hi4] (int16).
    const __m256i w01 = _mm256_packs_epi32(r0, r1);
    const __m256i w23 = _mm256_packs_epi32(r2, r3);
    // Dwords of b hold elements [0..3, 8..11, 16..19, 24..27 | 4..7, 12..15, 20..23, 28..31].
    const __m256i b = _mm256_packs_epi16(w01, w23);
    const __m256i fix = _mm256_permutevar8x32_epi32(b, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(po + i), fix);
  }
  add_i8_ref_range(a, i, n);
}

}  // namespace ef::nn
