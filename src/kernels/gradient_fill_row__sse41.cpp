// gradient_fill_row for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane
// masks as all-ones float lanes.
#include <smmintrin.h>

#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 {
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
  static M gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static F select(M m, F a, F b) { return _mm_blendv_ps(b, a, m); }
};
}  // namespace

void gradient_fill_row__sse41(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                              float* filled) {
  gradient_fill_row_simd<Sse41>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
