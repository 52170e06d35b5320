// Internal to the SSE4.1 variants of the row kernels written over a vector-ops type (pyramid_row,
// normal_row, gradient_fill_row): the float operations they share, 4 lanes in xmm registers, lane
// masks as all-ones float lanes. Each family's type derives from it and adds its own loads. Internal
// linkage (an anonymous namespace): the rule for ISA files in kernels/variants.h.
#pragma once

#include <smmintrin.h>

#include <cstdint>

namespace ef::kernels {
namespace {

struct F32Sse41 {
  using F = __m128;
  using M = __m128;
  static constexpr int kWidth = 4;
  static F set1(float x) { return _mm_set1_ps(x); }
  static F load(const float* p) { return _mm_loadu_ps(p); }
  static void store(float* p, F x) { _mm_storeu_ps(p, x); }
  static F add(F a, F b) { return _mm_add_ps(a, b); }
  static F sub(F a, F b) { return _mm_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm_mul_ps(a, b); }
  static F div(F a, F b) { return _mm_div_ps(a, b); }
  static F sqrt(F a) { return _mm_sqrt_ps(a); }
  static F abs(F a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(INT32_MAX))); }
  static M gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static M lt(F a, F b) { return _mm_cmplt_ps(a, b); }
  static M le(F a, F b) { return _mm_cmple_ps(a, b); }
  static M ne(F a, F b) { return _mm_cmpneq_ps(a, b); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return _mm_and_ps(a, b); }
  static F select(M m, F a, F b) { return _mm_blendv_ps(b, a, m); }  // a where m, else b
};

}  // namespace
}  // namespace ef::kernels
