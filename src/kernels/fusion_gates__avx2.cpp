// fusion_gates for AVX2: 8 pixels per step in ymm registers, lane masks as all-ones float lanes. The
// 4-float surfaces of 8 index pixels are de-interleaved with two lane permutes and an in-lane 4x4
// transpose.
#include <immintrin.h>

#include "kernels/f32_ops_avx2.h"
#include "kernels/fusion_gates_simd.h"

namespace ef::kernels {

namespace {
struct Avx2 : F32Avx2 {
  static I iload(const int32_t* p) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)); }
  static void istore(uint32_t* p, I x) { _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), x); }
  static I iota() { return _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7); }
  static void load_surfaces(const float* p, F& x, F& y, F& z) {
    const F a = load(p), b = load(p + 8), c = load(p + 16), d = load(p + 24);  // cells 01, 23, 45, 67
    const F t0 = _mm256_permute2f128_ps(a, c, 0x20), t1 = _mm256_permute2f128_ps(a, c, 0x31);  // 0|4, 1|5
    const F t2 = _mm256_permute2f128_ps(b, d, 0x20), t3 = _mm256_permute2f128_ps(b, d, 0x31);  // 2|6, 3|7
    const F u0 = _mm256_unpacklo_ps(t0, t1), u1 = _mm256_unpackhi_ps(t0, t1);  // x0 x1 y0 y1, z0 z1 w0 w1
    const F u2 = _mm256_unpacklo_ps(t2, t3), u3 = _mm256_unpackhi_ps(t2, t3);  // x2 x3 y2 y3, z2 z3 w2 w3
    x = _mm256_shuffle_ps(u0, u2, 0x44);
    y = _mm256_shuffle_ps(u0, u2, 0xEE);
    z = _mm256_shuffle_ps(u1, u3, 0x44);
  }
  static I set_bits(I c, M m, uint32_t bits) {
    return _mm256_or_si256(c, _mm256_and_si256(_mm256_castps_si256(m), _mm256_set1_epi32(static_cast<int>(bits))));
  }
};
}  // namespace

void fusion_gates__avx2(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  fusion_gates_simd<Avx2>(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
