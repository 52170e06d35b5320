// Internal to the AVX2 variants of the kernels written over a vector-ops type (bilateral_row,
// fusion_gates, track_rows, crf_rows, reduce_normal_equations (AVX2 and AVX-512 both take the AVX2
// type there), pyramid_row, normal_row, gradient_fill_row): the float and int32 operations they
// share, 8 lanes in ymm registers, lane masks as all-ones float lanes (separate multiply and add:
// contraction off, although the files are built with -mfma). Each family's type derives from it (or
// is it) and adds its own loads. Internal linkage (an anonymous namespace): the rule for ISA files
// in kernels/variants.h.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace ef::kernels {
namespace {

struct F32Avx2 {
  using F = __m256;
  using I = __m256i;
  using M = __m256;
  static constexpr int kWidth = 8;
  static F set1(float x) { return _mm256_set1_ps(x); }
  static F zero() { return _mm256_setzero_ps(); }
  static F load(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, F x) { _mm256_storeu_ps(p, x); }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }  // read hint
  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static F sqrt(F a) { return _mm256_sqrt_ps(a); }
  static F neg(F a) { return _mm256_xor_ps(a, _mm256_set1_ps(-0.0f)); }
  static F abs(F a) { return _mm256_and_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(INT32_MAX))); }
  static F floor(F a) { return _mm256_floor_ps(a); }
  static F ceil(F a) { return _mm256_ceil_ps(a); }
  static I cvtt(F a) { return _mm256_cvttps_epi32(a); }  // toward zero
  static F cvt(I a) { return _mm256_cvtepi32_ps(a); }
  static M gt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  static M ge(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
  static M lt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
  static M le(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  static M eq(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
  static M ne(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return _mm256_and_ps(a, b); }
  static M lor(M a, M b) { return _mm256_or_ps(a, b); }
  static M lnot(M a) { return _mm256_xor_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(-1))); }
  static bool any(M m) { return _mm256_movemask_ps(m) != 0; }
  static int count(M m) { return __builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(m))); }
  static F keep(M m, F a) { return _mm256_and_ps(m, a); }  // a where m, else 0
  static F select(M m, F a, F b) { return _mm256_blendv_ps(b, a, m); }  // a where m, else b
  static I iset1(int x) { return _mm256_set1_epi32(x); }
  static I iadd(I a, I b) { return _mm256_add_epi32(a, b); }
  static I imul(I a, I b) { return _mm256_mullo_epi32(a, b); }
  static M igt(I a, I b) { return _mm256_castsi256_ps(_mm256_cmpgt_epi32(a, b)); }
  static I ikeep(M m, I a) { return _mm256_and_si256(_mm256_castps_si256(m), a); }
};

}  // namespace
}  // namespace ef::kernels
