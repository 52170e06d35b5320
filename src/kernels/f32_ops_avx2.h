// Internal to the AVX2 variants of the row kernels written over a vector-ops type (pyramid_row,
// normal_row, gradient_fill_row): the float operations they share, 8 lanes in ymm registers, lane
// masks as all-ones float lanes (separate multiply and add: contraction off, although the files are
// built with -mfma). Each family's type derives from it and adds its own loads. Internal linkage (an
// anonymous namespace): the rule for ISA files in kernels/variants.h.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace ef::kernels {
namespace {

struct F32Avx2 {
  using F = __m256;
  using M = __m256;
  static constexpr int kWidth = 8;
  static F set1(float x) { return _mm256_set1_ps(x); }
  static F load(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, F x) { _mm256_storeu_ps(p, x); }
  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static F sqrt(F a) { return _mm256_sqrt_ps(a); }
  static F abs(F a) { return _mm256_and_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(INT32_MAX))); }
  static M gt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  static M lt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
  static M le(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  static M ne(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return _mm256_and_ps(a, b); }
  static F select(M m, F a, F b) { return _mm256_blendv_ps(b, a, m); }  // a where m, else b
};

}  // namespace
}  // namespace ef::kernels
