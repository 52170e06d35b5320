// gradient_fill_row at the AVX-512 level: 16 pixels per step in zmm registers, masks in k registers
// (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
#include <immintrin.h>

#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

namespace {
struct Avx512 {
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
  static M gt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
  static F select(M m, F a, F b) { return _mm512_mask_blend_ps(m, b, a); }
};
}  // namespace

void gradient_fill_row__avx512vnni(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                                   float* filled) {
  gradient_fill_row_simd<Avx512>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
