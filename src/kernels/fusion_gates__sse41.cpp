// fusion_gates for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes; the 4-float surfaces of 4 index pixels are one 4x4 transpose.
#include <smmintrin.h>

#include "kernels/f32_ops_sse41.h"
#include "kernels/fusion_gates_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 : F32Sse41 {
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
  static I set_bits(I c, M m, uint32_t bits) {
    return _mm_or_si128(c, _mm_and_si128(_mm_castps_si128(m), _mm_set1_epi32(static_cast<int>(bits))));
  }
};
}  // namespace

void fusion_gates__sse41(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  fusion_gates_simd<Sse41>(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
