// track_rows at the AVX-512 level: 16 pixels per step in zmm registers, lane masks in k registers
// (AVX-512 F/DQ; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
// The reference maps are read with gathers: VGATHERDPD of float pairs (the two bilinear taps of an
// image row, x and y of a vertex or normal) and VGATHERDPS for single floats; xyz triples of the
// current frame are de-interleaved with two masked blends and one VPERMPS per component.
#include <immintrin.h>

#include "kernels/track_rows_simd.h"

namespace ef::kernels {

namespace {
struct Avx512 {
  using F = __m512;
  using I = __m512i;
  using M = __mmask16;
  static constexpr int kWidth = 16;
  // The all-lanes mask: GCC 12 warns (-Wmaybe-uninitialized) about the unmasked forms of several
  // intrinsics, which merge into _mm512_undefined_*(); the maskz / mask forms with every lane set
  // are the same instructions without that false warning.
  static constexpr M kAll = static_cast<M>(0xFFFF);
  static F set1(float x) { return _mm512_set1_ps(x); }
  static F zero() { return _mm512_setzero_ps(); }
  static F load(const float* p) { return _mm512_loadu_ps(p); }
  static void store(float* p, F x) { _mm512_storeu_ps(p, x); }
  template <int comp>
  static F component(F a, F b, F c) {
#define EF_P(k) tr_perm(kWidth, comp, k)
    const I idx = _mm512_setr_epi32(EF_P(0), EF_P(1), EF_P(2), EF_P(3), EF_P(4), EF_P(5), EF_P(6), EF_P(7), EF_P(8),
                                    EF_P(9), EF_P(10), EF_P(11), EF_P(12), EF_P(13), EF_P(14), EF_P(15));
#undef EF_P
    constexpr M from_b = static_cast<M>(tr_mask(kWidth, comp, 1)), from_c = static_cast<M>(tr_mask(kWidth, comp, 2));
    return _mm512_maskz_permutexvar_ps(kAll, idx, _mm512_mask_blend_ps(from_c, _mm512_mask_blend_ps(from_b, a, b), c));
  }
  static void load3(const float* p, F& x, F& y, F& z) {
    const F a = load(p), b = load(p + 16), c = load(p + 32);
    x = component<0>(a, b, c);
    y = component<1>(a, b, c);
    z = component<2>(a, b, c);
  }
  static F add(F a, F b) { return _mm512_add_ps(a, b); }
  static F sub(F a, F b) { return _mm512_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm512_mul_ps(a, b); }
  static F div(F a, F b) { return _mm512_div_ps(a, b); }
  static F neg(F a) {
    return _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a), _mm512_set1_epi32(INT32_MIN)));
  }
  static F abs(F a) {
    return _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(a), _mm512_set1_epi32(INT32_MAX)));
  }
  static F floor(F a) { return _mm512_maskz_roundscale_ps(kAll, a, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC); }
  static I cvtt(F a) { return _mm512_maskz_cvttps_epi32(kAll, a); }
  static F cvt(I a) { return _mm512_maskz_cvtepi32_ps(kAll, a); }
  static I iset1(int x) { return _mm512_set1_epi32(x); }
  static I iadd(I a, I b) { return _mm512_add_epi32(a, b); }
  static I imul(I a, I b) { return _mm512_mullo_epi32(a, b); }
  static M lt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
  static M le(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
  static M gt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
  static M ge(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
  static M ne(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ); }
  static M land(M a, M b) { return static_cast<M>(a & b); }
  static M lor(M a, M b) { return static_cast<M>(a | b); }
  static bool any(M m) { return m != 0; }
  static int count(M m) { return __builtin_popcount(static_cast<unsigned>(m)); }
  static F keep(M m, F a) { return _mm512_maskz_mov_ps(m, a); }
  static F select(M m, F a, F b) { return _mm512_mask_blend_ps(m, b, a); }
  static I ikeep(M m, I a) { return _mm512_maskz_mov_epi32(m, a); }
  static F gather(const float* base, I idx) { return _mm512_mask_i32gather_ps(zero(), kAll, idx, base, 4); }
  // Two VGATHERDPD of 8 float pairs, then the even and the odd floats of the 16 pairs.
  static void gather2(const float* base, I idx, F& lo, F& hi) {
    const __m512d none = _mm512_setzero_pd();
    const F g0 = _mm512_castpd_ps(
        _mm512_mask_i32gather_pd(none, static_cast<__mmask8>(0xFF),
                                 _mm512_maskz_extracti64x4_epi64(static_cast<__mmask8>(0xFF), idx, 0), base, 4));
    const F g1 = _mm512_castpd_ps(
        _mm512_mask_i32gather_pd(none, static_cast<__mmask8>(0xFF),
                                 _mm512_maskz_extracti64x4_epi64(static_cast<__mmask8>(0xFF), idx, 1), base, 4));
    const I even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    const I odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    lo = _mm512_permutex2var_ps(g0, even, g1);
    hi = _mm512_permutex2var_ps(g0, odd, g1);
  }
};
}  // namespace

void track_rows__avx512vnni(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                            const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows,
                            std::size_t stride, TrackRowsCounts* counts) {
  track_rows_simd<Avx512>(params, cur_vertex, cur_normal, cur_intensity, n, icp_rows, rgb_rows, stride, counts);
}

}  // namespace ef::kernels
