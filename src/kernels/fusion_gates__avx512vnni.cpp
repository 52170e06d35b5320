// fusion_gates at the AVX-512 level: 16 pixels per step in zmm registers, lane masks in k registers
// (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
// The 4-float surfaces of 16 index pixels are de-interleaved with two two-source permutes and one
// 128-bit block shuffle per component.
#include <immintrin.h>

#include "kernels/f32_ops_avx512.h"
#include "kernels/fusion_gates_simd.h"

namespace ef::kernels {

namespace {
struct Avx512 : F32Avx512 {
  static I iload(const int32_t* p) { return _mm512_loadu_si512(p); }
  static void istore(uint32_t* p, I x) { _mm512_storeu_si512(p, x); }
  static I iota() { return _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15); }
  // Component j of cells 0..7 (in a, b) in lanes 0..7 of one permute and of cells 8..15 (c, d) in
  // those of another; the low halves of the two make the 16 lanes.
  template <int j>
  static F component(F a, F b, F c, F d) {
    const I idx = _mm512_setr_epi32(j, j + 4, j + 8, j + 12, j + 16, j + 20, j + 24, j + 28, j, j + 4, j + 8, j + 12,
                                    j + 16, j + 20, j + 24, j + 28);
    const F lo = _mm512_maskz_permutex2var_ps(kAll, a, idx, b), hi = _mm512_maskz_permutex2var_ps(kAll, c, idx, d);
    return _mm512_maskz_shuffle_f32x4(kAll, lo, hi, 0x44);
  }
  static void load_surfaces(const float* p, F& x, F& y, F& z) {
    const F a = load(p), b = load(p + 16), c = load(p + 32), d = load(p + 48);
    x = component<0>(a, b, c, d);
    y = component<1>(a, b, c, d);
    z = component<2>(a, b, c, d);
  }
  static I set_bits(I c, M m, uint32_t bits) {
    return _mm512_mask_or_epi32(c, m, c, _mm512_set1_epi32(static_cast<int>(bits)));
  }
};
}  // namespace

void fusion_gates__avx512vnni(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end,
                              uint32_t* code) {
  fusion_gates_simd<Avx512>(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
