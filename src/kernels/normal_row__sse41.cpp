// normal_row for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes. Three components of four pixels are three loads; two blends and a shuffle
// gather each component (and the same in reverse to store).
#include <smmintrin.h>

#include <cstdint>

#include "kernels/normal_row_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 {
  using F = __m128;
  using M = __m128;
  static constexpr int kWidth = 4;
  static F set1(float x) { return _mm_set1_ps(x); }
  // a = x0 y0 z0 x1, b = y1 z1 x2 y2, c = z2 x3 y3 z3.
  static void load3(const float* p, F& x, F& y, F& z) {
    const F a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), c = _mm_loadu_ps(p + 8);
    const F mx = _mm_blend_ps(_mm_blend_ps(a, b, 0x4), c, 0x2);  // x0 x3 x2 x1
    const F my = _mm_blend_ps(_mm_blend_ps(a, b, 0x9), c, 0x4);  // y1 y0 y3 y2
    const F mz = _mm_blend_ps(_mm_blend_ps(a, b, 0x2), c, 0x9);  // z2 z1 z0 z3
    x = _mm_shuffle_ps(mx, mx, _MM_SHUFFLE(1, 2, 3, 0));
    y = _mm_shuffle_ps(my, my, _MM_SHUFFLE(2, 3, 0, 1));
    z = _mm_shuffle_ps(mz, mz, _MM_SHUFFLE(3, 0, 1, 2));
  }
  static void store3(float* p, F x, F y, F z) {
    const F mx = _mm_shuffle_ps(x, x, _MM_SHUFFLE(1, 2, 3, 0));  // x0 x3 x2 x1
    const F my = _mm_shuffle_ps(y, y, _MM_SHUFFLE(2, 3, 0, 1));  // y1 y0 y3 y2
    const F mz = _mm_shuffle_ps(z, z, _MM_SHUFFLE(3, 0, 1, 2));  // z2 z1 z0 z3
    _mm_storeu_ps(p, _mm_blend_ps(_mm_blend_ps(mx, my, 0x2), mz, 0x4));
    _mm_storeu_ps(p + 4, _mm_blend_ps(_mm_blend_ps(my, mz, 0x2), mx, 0x4));
    _mm_storeu_ps(p + 8, _mm_blend_ps(_mm_blend_ps(mz, mx, 0x2), my, 0x4));
  }
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
