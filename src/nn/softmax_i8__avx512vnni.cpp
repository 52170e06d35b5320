// softmax_i8 at the AVX-512 level (needs F only; named __avx512vnni, see kernels/variants.h): 16
// pixels per vector (one class of 16 pixels per zmm). The 4-class words of the 16 pixels come from
// one VPGATHERDD, the classes out of them by VPSLLD / VPSRAD, the table entries from VGATHERDPS; the
// max (VPMAXSD), the float32 sum in class order (VADDPS), 1 / sum (VDIVPS) and the products run on
// 16 pixels at once. The loop nest is nn/softmax_i8_simd.h.
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"

#include "nn/eltwise_kernels.h"
#include "nn/softmax_i8_simd.h"

namespace ef::nn {
namespace {

struct SoftmaxZ16 {
  static constexpr int kPixels = 16;
  using I = __m512i;
  using F = __m512;
  using Offs = __m512i;  // l * C: byte offset of pixel l
  static Offs offsets(int C) {
    return _mm512_mullo_epi32(_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                              _mm512_set1_epi32(C));
  }
  static I load_words(const int8_t* q, const Offs& o, int c) { return _mm512_i32gather_epi32(o, q + c, 1); }
  static I byte(I w, int k) { return _mm512_srai_epi32(_mm512_sll_epi32(w, _mm_cvtsi32_si128(24 - 8 * k)), 24); }
  static I splat_i(int v) { return _mm512_set1_epi32(v); }
  static I max_i(I a, I b) { return _mm512_max_epi32(a, b); }
  static I sub_i(I a, I b) { return _mm512_sub_epi32(a, b); }
  static void store_i(int32_t* p, I v) { _mm512_store_si512(p, v); }
  static I load_i(const int32_t* p) { return _mm512_load_si512(p); }
  static F lookup(const float* t, I d) { return _mm512_i32gather_ps(d, t, 4); }
  static F zero_f() { return _mm512_setzero_ps(); }
  static F add_f(F a, F b) { return _mm512_add_ps(a, b); }
  static F recip(F s) { return _mm512_div_ps(_mm512_set1_ps(1.0f), s); }
  static void store_f(float* p, F v) { _mm512_store_ps(p, v); }
};

}  // namespace

void softmax_i8__avx512vnni(const SoftmaxArgs& a) { softmax_pixels<SoftmaxZ16, SoftmaxT4>(a); }

}  // namespace ef::nn
