// Internal to the AVX2 variants of the kernels written over a vector-ops type (bilateral_row,
// fusion_gates, track_rows, crf_rows, reduce_normal_equations (AVX2 and AVX-512 both take the AVX2
// type there), pyramid_row, normal_row, gradient_fill_row): the float and int32 operations they
// share, 8 lanes in ymm registers, lane masks as all-ones float lanes (separate multiply and add:
// contraction off, although the files are built with -mfma), and the de-interleave of xyz triples
// (load3 / store3) that normal_row and track_rows read vertices and normals with. Each family's type
// derives from it (or is it) and adds its own loads. Internal linkage (an anonymous namespace): the
// rule for ISA files in kernels/variants.h.
#pragma once

#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_sse41.h"

namespace ef::kernels {
namespace {

// De-interleaving `width` xyz triples held in three registers a, b, c (flat floats 0 .. 3 width - 1):
// lane k of component comp is flat element 3 k + comp. Because 3 is coprime with the width, the
// lanes of one component land on distinct positions (3 k + comp) mod width, so one blend of a, b, c
// per position followed by one permutation gives the component. xyz_src: which register (0 a, 1 b,
// 2 c) supplies position pos; xyz_perm: the position that lane k reads after the blend; xyz_mask: bit
// pos set when register src supplies position pos (the blend's immediate).
constexpr int xyz_src(int width, int comp, int pos) {
  for (int k = 0; k < width; ++k)
    if ((3 * k + comp) % width == pos) return (3 * k + comp) / width;
  return 0;
}
constexpr int xyz_perm(int width, int comp, int k) { return (3 * k + comp) % width; }
constexpr unsigned xyz_mask(int width, int comp, int src) {
  unsigned m = 0;
  for (int pos = 0; pos < width; ++pos)
    if (xyz_src(width, comp, pos) == src) m |= 1u << pos;
  return m;
}

struct F32Avx2 {
  using F = __m256;
  using I = __m256i;
  using M = __m256;
  static constexpr int kWidth = 8;
  static F set1(float x) { return _mm256_set1_ps(x); }
  static F zero() { return _mm256_setzero_ps(); }
  static F load(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, F x) { _mm256_storeu_ps(p, x); }
  // Eight xyz triples (24 floats): each component is two blends of the three loads and one VPERMPS.
  template <int comp>
  static F xyz_component(F a, F b, F c) {
    const I idx = _mm256_setr_epi32(xyz_perm(8, comp, 0), xyz_perm(8, comp, 1), xyz_perm(8, comp, 2),
                                    xyz_perm(8, comp, 3), xyz_perm(8, comp, 4), xyz_perm(8, comp, 5),
                                    xyz_perm(8, comp, 6), xyz_perm(8, comp, 7));
    constexpr int from_b = static_cast<int>(xyz_mask(8, comp, 1)), from_c = static_cast<int>(xyz_mask(8, comp, 2));
    return _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, from_b), c, from_c), idx);
  }
  static void load3(const float* p, F& x, F& y, F& z) {
    const F a = _mm256_loadu_ps(p), b = _mm256_loadu_ps(p + 8), c = _mm256_loadu_ps(p + 16);
    x = xyz_component<0>(a, b, c);
    y = xyz_component<1>(a, b, c);
    z = xyz_component<2>(a, b, c);
  }
  // Storing: the SSE4.1 form on each half (four triples each).
  static void store3(float* p, F x, F y, F z) {
    F32Sse41::store3(p, _mm256_castps256_ps128(x), _mm256_castps256_ps128(y), _mm256_castps256_ps128(z));
    F32Sse41::store3(p + 12, _mm256_extractf128_ps(x, 1), _mm256_extractf128_ps(y, 1), _mm256_extractf128_ps(z, 1));
  }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }  // read hint
  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static F sqrt(F a) { return _mm256_sqrt_ps(a); }
  static F neg(F a) { return _mm256_xor_ps(a, _mm256_set1_ps(-0.0f)); }
  static F abs(F a) { return _mm256_and_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(INT32_MAX))); }
  static F floor(F a) { return _mm256_floor_ps(a); }
  static F ceil(F a) { return _mm256_ceil_ps(a); }
  static I cvtt(F a) { return _mm256_cvttps_epi32(a); }  // toward zero
  static F cvt(I a) { return _mm256_cvtepi32_ps(a); }
  static M gt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  static M ge(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
  static M lt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
  static M le(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  static M eq(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
  static M ne(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return _mm256_and_ps(a, b); }
  static M lor(M a, M b) { return _mm256_or_ps(a, b); }
  static M lnot(M a) { return _mm256_xor_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(-1))); }
  static bool any(M m) { return _mm256_movemask_ps(m) != 0; }
  static int count(M m) { return __builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(m))); }
  static F keep(M m, F a) { return _mm256_and_ps(m, a); }  // a where m, else 0
  static F select(M m, F a, F b) { return _mm256_blendv_ps(b, a, m); }  // a where m, else b
  static I iset1(int x) { return _mm256_set1_epi32(x); }
  static I iadd(I a, I b) { return _mm256_add_epi32(a, b); }
  static I imul(I a, I b) { return _mm256_mullo_epi32(a, b); }
  static M igt(I a, I b) { return _mm256_castsi256_ps(_mm256_cmpgt_epi32(a, b)); }
  static I ikeep(M m, I a) { return _mm256_and_si256(_mm256_castps_si256(m), a); }
};

}  // namespace
}  // namespace ef::kernels
