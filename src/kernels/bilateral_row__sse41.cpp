// bilateral_row for SSE4.1 (the x86-64 baseline): 4 output pixels per step in xmm registers.
#include <smmintrin.h>

#include "kernels/bilateral_row_simd.h"

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
  static F keep(M m, F a) { return _mm_and_ps(m, a); }
};
}  // namespace

void bilateral_row__sse41(const BilateralRow& b, int width, float* out) { bilateral_row_simd<Sse41>(b, width, out); }

}  // namespace ef::kernels
