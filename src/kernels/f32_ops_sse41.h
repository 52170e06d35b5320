// Internal to the SSE4.1 variants of the kernels written over a vector-ops type (bilateral_row,
// fusion_gates, track_rows, crf_rows, reduce_normal_equations, pyramid_row, normal_row,
// gradient_fill_row): the float and int32 operations they share, 4 lanes in xmm registers, lane
// masks as all-ones float lanes. Each family's type derives from it (or is it) and adds its own
// loads. Internal linkage (an anonymous namespace): the rule for ISA files in kernels/variants.h.
#pragma once

#include <smmintrin.h>

#include <cstdint>

namespace ef::kernels {
namespace {

struct F32Sse41 {
  using F = __m128;
  using I = __m128i;
  using M = __m128;
  static constexpr int kWidth = 4;
  static F set1(float x) { return _mm_set1_ps(x); }
  static F zero() { return _mm_setzero_ps(); }
  static F load(const float* p) { return _mm_loadu_ps(p); }
  static void store(float* p, F x) { _mm_storeu_ps(p, x); }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }  // read hint
  static F add(F a, F b) { return _mm_add_ps(a, b); }
  static F sub(F a, F b) { return _mm_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm_mul_ps(a, b); }
  static F div(F a, F b) { return _mm_div_ps(a, b); }
  static F sqrt(F a) { return _mm_sqrt_ps(a); }
  static F neg(F a) { return _mm_xor_ps(a, _mm_set1_ps(-0.0f)); }
  static F abs(F a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(INT32_MAX))); }
  static F floor(F a) { return _mm_floor_ps(a); }
  static F ceil(F a) { return _mm_ceil_ps(a); }
  static I cvtt(F a) { return _mm_cvttps_epi32(a); }  // toward zero
  static F cvt(I a) { return _mm_cvtepi32_ps(a); }
  static M gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static M ge(F a, F b) { return _mm_cmpge_ps(a, b); }
  static M lt(F a, F b) { return _mm_cmplt_ps(a, b); }
  static M le(F a, F b) { return _mm_cmple_ps(a, b); }
  static M eq(F a, F b) { return _mm_cmpeq_ps(a, b); }
  static M ne(F a, F b) { return _mm_cmpneq_ps(a, b); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return _mm_and_ps(a, b); }
  static M lor(M a, M b) { return _mm_or_ps(a, b); }
  static M lnot(M a) { return _mm_xor_ps(a, _mm_castsi128_ps(_mm_set1_epi32(-1))); }
  static bool any(M m) { return _mm_movemask_ps(m) != 0; }
  static int count(M m) { return __builtin_popcount(static_cast<unsigned>(_mm_movemask_ps(m))); }
  static F keep(M m, F a) { return _mm_and_ps(m, a); }  // a where m, else 0
  static F select(M m, F a, F b) { return _mm_blendv_ps(b, a, m); }  // a where m, else b
  static I iset1(int x) { return _mm_set1_epi32(x); }
  static I iadd(I a, I b) { return _mm_add_epi32(a, b); }
  static I imul(I a, I b) { return _mm_mullo_epi32(a, b); }
  static M igt(I a, I b) { return _mm_castsi128_ps(_mm_cmpgt_epi32(a, b)); }
  static I ikeep(M m, I a) { return _mm_and_si128(_mm_castps_si128(m), a); }
};

}  // namespace
}  // namespace ef::kernels
