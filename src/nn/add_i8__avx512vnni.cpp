// add_i8 at the AVX-512 level (needs F and BW only; named __avx512vnni, see kernels/variants.h):
// 64 elements per step, the last n mod 64 with byte-masked loads and stores (no scalar tail). Each
// quarter of 16 bytes is sign-extended to int32, float(a - za) * ma + float(b - zb) * mb computed
// with two VMULPS and one VADDPS (no FMA), clamped, rounded half to even (VCVTPS2DQ), offset by the
// output zero point and narrowed with VPMOVSDB (values already in range). Both inputs are loaded
// before the store, so out may alias a or b.
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"

#include <immintrin.h>

#include <cstddef>

#include "nn/eltwise_kernels.h"

namespace ef::nn {

namespace {

struct Consts {
  __m512i za, zb, zo;
  __m512 ma, mb, lo, hi;
};

__m128i quarter(__m128i a8, __m128i b8, const Consts& k) {
  const __m512 ya = _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_sub_epi32(_mm512_cvtepi8_epi32(a8), k.za)), k.ma);
  const __m512 yb = _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_sub_epi32(_mm512_cvtepi8_epi32(b8), k.zb)), k.mb);
  __m512 y = _mm512_add_ps(ya, yb);
  y = _mm512_min_ps(_mm512_max_ps(y, k.lo), k.hi);
  return _mm512_cvtsepi32_epi8(_mm512_add_epi32(_mm512_cvtps_epi32(y), k.zo));
}

__m512i block(__m512i va, __m512i vb, const Consts& k) {
  const __m128i q0 = quarter(_mm512_castsi512_si128(va), _mm512_castsi512_si128(vb), k);
  const __m128i q1 = quarter(_mm512_extracti32x4_epi32(va, 1), _mm512_extracti32x4_epi32(vb, 1), k);
  const __m128i q2 = quarter(_mm512_extracti32x4_epi32(va, 2), _mm512_extracti32x4_epi32(vb, 2), k);
  const __m128i q3 = quarter(_mm512_extracti32x4_epi32(va, 3), _mm512_extracti32x4_epi32(vb, 3), k);
  __m512i r = _mm512_zextsi128_si512(q0);
  r = _mm512_inserti32x4(r, q1, 1);
  r = _mm512_inserti32x4(r, q2, 2);
  return _mm512_inserti32x4(r, q3, 3);
}

}  // namespace

void add_i8__avx512vnni(const AddArgs& a) {
  const std::size_t n = std::size_t(a.out.h) * a.out.w * a.out.c;
  Consts k;
  k.za = _mm512_set1_epi32(a.a.zero_point);
  k.zb = _mm512_set1_epi32(a.b.zero_point);
  k.zo = _mm512_set1_epi32(a.out.zero_point);
  k.ma = _mm512_set1_ps(a.rq_a.multiplier);
  k.mb = _mm512_set1_ps(a.rq_b.multiplier);
  k.lo = _mm512_set1_ps(float(a.out_min - a.out.zero_point));
  k.hi = _mm512_set1_ps(float(a.out_max - a.out.zero_point));
  const int8_t* pa = a.a.data;
  const int8_t* pb = a.b.data;
  int8_t* po = a.out.data;
  std::size_t i = 0;
  for (; i + 64 <= n; i += 64) {
    const __m512i va = _mm512_loadu_si512(pa + i);
    const __m512i vb = _mm512_loadu_si512(pb + i);
    _mm512_storeu_si512(po + i, block(va, vb, k));
  }
  if (i < n) {
    const __mmask64 m = (__mmask64{1} << (n - i)) - 1;  // n - i in [1, 63]
    const __m512i va = _mm512_maskz_loadu_epi8(m, pa + i);
    const __m512i vb = _mm512_maskz_loadu_epi8(m, pb + i);
    _mm512_mask_storeu_epi8(po + i, m, block(va, vb, k));
  }
}

}  // namespace ef::nn
