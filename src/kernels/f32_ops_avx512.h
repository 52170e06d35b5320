// Internal to the AVX-512 variants of the row kernels written over a vector-ops type (pyramid_row,
// normal_row, gradient_fill_row): the float operations they share, 16 lanes in zmm registers, masks
// in k registers (AVX-512 F). Each family's type derives from it and adds its own loads. Internal
// linkage (an anonymous namespace): the rule for ISA files in kernels/variants.h.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace ef::kernels {
namespace {

struct F32Avx512 {
  using F = __m512;
  using M = __mmask16;
  static constexpr int kWidth = 16;
  static F set1(float x) { return _mm512_set1_ps(x); }
  static F load(const float* p) { return _mm512_loadu_ps(p); }
  static void store(float* p, F x) { _mm512_storeu_ps(p, x); }
  static F add(F a, F b) { return _mm512_add_ps(a, b); }
  static F sub(F a, F b) { return _mm512_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm512_mul_ps(a, b); }
  static F div(F a, F b) { return _mm512_div_ps(a, b); }
  // The zero-masked form with every lane: GCC 12's _mm512_sqrt_ps trips -Werror=uninitialized.
  static F sqrt(F a) { return _mm512_maskz_sqrt_ps(0xFFFF, a); }
  static F abs(F a) {
    return _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(a), _mm512_set1_epi32(INT32_MAX)));
  }
  static M gt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
  static M lt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
  static M le(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
  static M ne(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return static_cast<M>(a & b); }
  static F select(M m, F a, F b) { return _mm512_mask_blend_ps(m, b, a); }  // a where m, else b
};

}  // namespace
}  // namespace ef::kernels
