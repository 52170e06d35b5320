// normal_row for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes. Three components of four pixels are three loads, de-interleaved (and
// interleaved to store) by kernels/xyz4_sse.h.
#include <smmintrin.h>

#include <cstdint>

#include "kernels/normal_row_simd.h"
#include "kernels/xyz4_sse.h"

namespace ef::kernels {

namespace {
struct Sse41 {
  using F = __m128;
  using M = __m128;
  static constexpr int kWidth = 4;
  static F set1(float x) { return _mm_set1_ps(x); }
  static void load3(const float* p, F& x, F& y, F& z) { load_xyz4(p, x, y, z); }
  static void store3(float* p, F x, F y, F z) { store_xyz4(p, x, y, z); }
  static F add(F a, F b) { return _mm_add_ps(a, b); }
  static F sub(F a, F b) { return _mm_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm_mul_ps(a, b); }
  static F div(F a, F b) { return _mm_div_ps(a, b); }
  static F sqrt(F a) { return _mm_sqrt_ps(a); }
  static F abs(F a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(INT32_MAX))); }
  static M gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static M le(F a, F b) { return _mm_cmple_ps(a, b); }
  static M land(M a, M b) { return _mm_and_ps(a, b); }
  static F select(M m, F a, F b) { return _mm_blendv_ps(b, a, m); }
};
}  // namespace

void normal_row__sse41(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Sse41>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
