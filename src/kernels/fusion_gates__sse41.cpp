// fusion_gates for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes; the 4-float surfaces of 4 index pixels are one 4x4 transpose.
#include <smmintrin.h>

#include "kernels/fusion_gates_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 {
  using F = __m128;
  using I = __m128i;
  using M = __m128;
  static constexpr int kWidth = 4;
  static F set1(float x) { return _mm_set1_ps(x); }
  static F load(const float* p) { return _mm_loadu_ps(p); }
  static I iset1(int x) { return _mm_set1_epi32(x); }
  static I iload(const int32_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
  static void istore(uint32_t* p, I x) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), x); }
  static I iota() { return _mm_setr_epi32(0, 1, 2, 3); }
  static void load_surfaces(const float* p, F& x, F& y, F& z) {
    const F a = load(p), b = load(p + 4), c = load(p + 8), d = load(p + 12);
    const F u0 = _mm_unpacklo_ps(a, b), u1 = _mm_unpackhi_ps(a, b);  // x0 x1 y0 y1, z0 z1 w0 w1
    const F u2 = _mm_unpacklo_ps(c, d), u3 = _mm_unpackhi_ps(c, d);
    x = _mm_movelh_ps(u0, u2);
    y = _mm_movehl_ps(u2, u0);
    z = _mm_movelh_ps(u1, u3);
  }
  static F add(F a, F b) { return _mm_add_ps(a, b); }
  static F sub(F a, F b) { return _mm_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm_mul_ps(a, b); }
  static F abs(F a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(INT32_MAX))); }
  static F ceil(F a) { return _mm_ceil_ps(a); }
  static F cvt(I a) { return _mm_cvtepi32_ps(a); }
  static M lt(F a, F b) { return _mm_cmplt_ps(a, b); }
  static M gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static M eq(F a, F b) { return _mm_cmpeq_ps(a, b); }
  static M igt(I a, I b) { return _mm_castsi128_ps(_mm_cmpgt_epi32(a, b)); }
  static I iadd(I a, I b) { return _mm_add_epi32(a, b); }
  static M land(M a, M b) { return _mm_and_ps(a, b); }
  static M lor(M a, M b) { return _mm_or_ps(a, b); }
  static M lnot(M a) { return _mm_xor_ps(a, _mm_castsi128_ps(_mm_set1_epi32(-1))); }
  static I set_bits(I c, M m, uint32_t bits) {
    return _mm_or_si128(c, _mm_and_si128(_mm_castps_si128(m), _mm_set1_epi32(static_cast<int>(bits))));
  }
};
}  // namespace

void fusion_gates__sse41(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  fusion_gates_simd<Sse41>(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
