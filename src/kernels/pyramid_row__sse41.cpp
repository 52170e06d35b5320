// pyramid_row for SSE4.1 (the x86-64 baseline): 4 coarse pixels per step in xmm registers, lane masks
// as all-ones float lanes; a finer row's even and odd columns are two loads and two SHUFPS.
#include <smmintrin.h>

#include <cstdint>

#include "kernels/pyramid_row_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 {
  using F = __m128;
  using M = __m128;
  static constexpr int kWidth = 4;
  static F set1(float x) { return _mm_set1_ps(x); }
  static void store(float* p, F x) { _mm_storeu_ps(p, x); }
  static void load2(const float* p, F& even, F& odd) {
    const F a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4);
    even = _mm_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0));
    odd = _mm_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
  }
  static F add(F a, F b) { return _mm_add_ps(a, b); }
  static F sub(F a, F b) { return _mm_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm_mul_ps(a, b); }
  static F div(F a, F b) { return _mm_div_ps(a, b); }
  static F abs(F a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(INT32_MAX))); }
  static M gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static M lt(F a, F b) { return _mm_cmplt_ps(a, b); }
  static M le(F a, F b) { return _mm_cmple_ps(a, b); }
  static M ne(F a, F b) { return _mm_cmpneq_ps(a, b); }
  static M land(M a, M b) { return _mm_and_ps(a, b); }
  static F select(M m, F a, F b) { return _mm_blendv_ps(b, a, m); }
};
}  // namespace

void pyramid_row__sse41(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  pyramid_row_simd<Sse41>(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
