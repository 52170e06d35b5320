// add_i8 at the SSE4.1 level: 16 elements per step. Each step sign-extends four groups of four
// bytes to int32, subtracts the zero points, converts to float and computes
// float(a - za) * ma + float(b - zb) * mb (two MULPS and one ADDPS, no FMA), clamps with MAXPS /
// MINPS, rounds half to even with CVTPS2DQ, adds the output zero point and packs with saturation
// (values are already in range). Both inputs are loaded before the store, so out may alias a or b.
// The last n mod 16 elements go through add_i8_ref_range.
#include <smmintrin.h>

#include <cstddef>

#include "nn/eltwise_kernels.h"

namespace ef::nn {

namespace {

struct Consts {
  __m128i za, zb, zo;
  __m128 ma, mb, lo, hi;
};

__m128i quarter(__m128i a32, __m128i b32, const Consts& k) {
  const __m128 ya = _mm_mul_ps(_mm_cvtepi32_ps(_mm_sub_epi32(a32, k.za)), k.ma);
  const __m128 yb = _mm_mul_ps(_mm_cvtepi32_ps(_mm_sub_epi32(b32, k.zb)), k.mb);
  __m128 y = _mm_add_ps(ya, yb);
  y = _mm_min_ps(_mm_max_ps(y, k.lo), k.hi);
  return _mm_add_epi32(_mm_cvtps_epi32(y), k.zo);
}

}  // namespace

void add_i8__sse41(const AddArgs& a) {
  const std::size_t n = std::size_t(a.out.h) * a.out.w * a.out.c;
  Consts k;
  k.za = _mm_set1_epi32(a.a.zero_point);
  k.zb = _mm_set1_epi32(a.b.zero_point);
  k.zo = _mm_set1_epi32(a.out.zero_point);
  k.ma = _mm_set1_ps(a.rq_a.multiplier);
  k.mb = _mm_set1_ps(a.rq_b.multiplier);
  k.lo = _mm_set1_ps(float(a.out_min - a.out.zero_point));
  k.hi = _mm_set1_ps(float(a.out_max - a.out.zero_point));
  const int8_t* pa = a.a.data;
  const int8_t* pb = a.b.data;
  int8_t* po = a.out.data;
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pa + i));
    const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pb + i));
    const __m128i r0 = quarter(_mm_cvtepi8_epi32(va), _mm_cvtepi8_epi32(vb), k);
    const __m128i r1 = quarter(_mm_cvtepi8_epi32(_mm_srli_si128(va, 4)), _mm_cvtepi8_epi32(_mm_srli_si128(vb, 4)), k);
    const __m128i r2 = quarter(_mm_cvtepi8_epi32(_mm_srli_si128(va, 8)), _mm_cvtepi8_epi32(_mm_srli_si128(vb, 8)), k);
    const __m128i r3 = quarter(_mm_cvtepi8_epi32(_mm_srli_si128(va, 12)), _mm_cvtepi8_epi32(_mm_srli_si128(vb, 12)), k);
    const __m128i r = _mm_packs_epi16(_mm_packs_epi32(r0, r1), _mm_packs_epi32(r2, r3));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(po + i), r);
  }
  add_i8_ref_range(a, i, n);
}

}  // namespace ef::nn
