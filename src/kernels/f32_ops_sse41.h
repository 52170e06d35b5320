// Internal to the SSE4.1 variants of the kernels written over a vector-ops type (bilateral_row,
// fusion_gates, track_rows, crf_rows, reduce_normal_equations, pyramid_row, normal_row,
// gradient_fill_row): the float and int32 operations they share, 4 lanes in xmm registers, lane
// masks as all-ones float lanes, and the de-interleave of xyz triples (load3 / store3) that
// normal_row and track_rows read vertices and normals with. Each family's type derives from it (or
// is it) and adds its own loads. Internal linkage (an anonymous namespace): the rule for ISA files in
// kernels/variants.h.
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
  // Four xyz triples (12 floats) to and from registers of x, y and z. p: a = x0 y0 z0 x1,
  // b = y1 z1 x2 y2, c = z2 x3 y3 z3. Two blends put each component's four values into one register
  // in a known order (x0 x3 x2 x1, y1 y0 y3 y2, z2 z1 z0 z3), a shuffle sorts them; storing is the
  // same shuffles (each its own inverse), then blends.
  static void load3(const float* p, F& x, F& y, F& z) {
    const F a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), c = _mm_loadu_ps(p + 8);
    const F mx = _mm_blend_ps(_mm_blend_ps(a, b, 0x4), c, 0x2);
    const F my = _mm_blend_ps(_mm_blend_ps(a, b, 0x9), c, 0x4);
    const F mz = _mm_blend_ps(_mm_blend_ps(a, b, 0x2), c, 0x9);
    x = _mm_shuffle_ps(mx, mx, _MM_SHUFFLE(1, 2, 3, 0));
    y = _mm_shuffle_ps(my, my, _MM_SHUFFLE(2, 3, 0, 1));
    z = _mm_shuffle_ps(mz, mz, _MM_SHUFFLE(3, 0, 1, 2));
  }
  static void store3(float* p, F x, F y, F z) {
    const F mx = _mm_shuffle_ps(x, x, _MM_SHUFFLE(1, 2, 3, 0));
    const F my = _mm_shuffle_ps(y, y, _MM_SHUFFLE(2, 3, 0, 1));
    const F mz = _mm_shuffle_ps(z, z, _MM_SHUFFLE(3, 0, 1, 2));
    _mm_storeu_ps(p, _mm_blend_ps(_mm_blend_ps(mx, my, 0x2), mz, 0x4));
    _mm_storeu_ps(p + 4, _mm_blend_ps(_mm_blend_ps(my, mz, 0x2), mx, 0x4));
    _mm_storeu_ps(p + 8, _mm_blend_ps(_mm_blend_ps(mz, mx, 0x2), my, 0x4));
  }
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
