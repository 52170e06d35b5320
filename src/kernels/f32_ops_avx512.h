// Internal to the AVX-512 variants of the kernels written over a vector-ops type (bilateral_row,
// fusion_gates, track_rows, crf_rows, pyramid_row, normal_row, gradient_fill_row): the float and
// int32 operations they share, 16 lanes in zmm registers, masks in k registers (AVX-512 F), and the
// de-interleave of xyz triples (load3 / store3) that normal_row and track_rows read vertices and
// normals with. Each family's type derives from it (or is it) and adds its own loads. Internal
// linkage (an anonymous namespace): the rule for ISA files in kernels/variants.h.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace ef::kernels {
namespace {

// Index tables of load3's and store3's permutes. Gathering component k: lane i takes float
// g = 3 i + k of the 48, first from loads a, b (g < 32: index g) and then from load c (index
// 16 + g - 32, else keep lane i). Scattering: float g of store s (g = 16 s + e) is component g % 3 of
// pixel g / 3, taken from x and y first, then z. Computed by the compiler (a constexpr object: no
// start-up code compiled for AVX-512, which would run on every CPU).
struct XyzTables {
  int32_t gather_ab[3][16]{}, gather_c[3][16]{}, scatter_xy[3][16]{}, scatter_z[3][16]{};
  constexpr XyzTables() {
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 16; ++i) {
        const int g = 3 * i + k;
        gather_ab[k][i] = g < 32 ? g : 0;
        gather_c[k][i] = g < 32 ? i : 16 + g - 32;
      }
    for (int s = 0; s < 3; ++s)
      for (int e = 0; e < 16; ++e) {
        const int g = 16 * s + e, pixel = g / 3, comp = g % 3;
        scatter_xy[s][e] = comp == 0 ? pixel : comp == 1 ? 16 + pixel : 0;
        scatter_z[s][e] = comp == 2 ? 16 + pixel : e;
      }
  }
};
constexpr XyzTables kXyzTables;

struct F32Avx512 {
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
  // Sixteen xyz triples (48 floats) are three loads; two VPERMT2PS gather each component (the first
  // from the first two loads, the second adds the third), and the same in reverse to store.
  static void load3(const float* p, F& x, F& y, F& z) {
    const F a = _mm512_loadu_ps(p), b = _mm512_loadu_ps(p + 16), c = _mm512_loadu_ps(p + 32);
    F* out[3] = {&x, &y, &z};
    for (int k = 0; k < 3; ++k) {
      const F ab = _mm512_permutex2var_ps(a, _mm512_loadu_si512(kXyzTables.gather_ab[k]), b);
      *out[k] = _mm512_permutex2var_ps(ab, _mm512_loadu_si512(kXyzTables.gather_c[k]), c);
    }
  }
  static void store3(float* p, F x, F y, F z) {
    for (int s = 0; s < 3; ++s) {
      const F xy = _mm512_permutex2var_ps(x, _mm512_loadu_si512(kXyzTables.scatter_xy[s]), y);
      _mm512_storeu_ps(p + 16 * s, _mm512_permutex2var_ps(xy, _mm512_loadu_si512(kXyzTables.scatter_z[s]), z));
    }
  }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }  // read hint
  static F add(F a, F b) { return _mm512_add_ps(a, b); }
  static F sub(F a, F b) { return _mm512_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm512_mul_ps(a, b); }
  static F div(F a, F b) { return _mm512_div_ps(a, b); }
  // The zero-masked form with every lane: GCC 12's _mm512_sqrt_ps trips -Werror=uninitialized.
  static F sqrt(F a) { return _mm512_maskz_sqrt_ps(0xFFFF, a); }
  static F abs(F a) {
    return _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(a), _mm512_set1_epi32(INT32_MAX)));
  }
  static F neg(F a) {
    return _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a), _mm512_set1_epi32(INT32_MIN)));
  }
  static F floor(F a) { return _mm512_maskz_roundscale_ps(kAll, a, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC); }
  static F ceil(F a) { return _mm512_maskz_roundscale_ps(kAll, a, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC); }
  static I cvtt(F a) { return _mm512_maskz_cvttps_epi32(kAll, a); }  // toward zero
  static F cvt(I a) { return _mm512_maskz_cvtepi32_ps(kAll, a); }
  static M gt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
  static M ge(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
  static M lt(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
  static M le(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
  static M eq(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ); }
  static M ne(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return static_cast<M>(a & b); }
  static M lor(M a, M b) { return static_cast<M>(a | b); }
  static M lnot(M a) { return static_cast<M>(~a); }
  static bool any(M m) { return m != 0; }
  static int count(M m) { return __builtin_popcount(static_cast<unsigned>(m)); }
  static F keep(M m, F a) { return _mm512_maskz_mov_ps(m, a); }  // a where m, else 0
  static F select(M m, F a, F b) { return _mm512_mask_blend_ps(m, b, a); }  // a where m, else b
  static I iset1(int x) { return _mm512_set1_epi32(x); }
  static I iadd(I a, I b) { return _mm512_add_epi32(a, b); }
  static I imul(I a, I b) { return _mm512_mullo_epi32(a, b); }
  static M igt(I a, I b) { return _mm512_cmpgt_epi32_mask(a, b); }
  static I ikeep(M m, I a) { return _mm512_maskz_mov_epi32(m, a); }
};

}  // namespace
}  // namespace ef::kernels
