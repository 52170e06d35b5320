// softmax_i8 at the AVX2 level: 8 pixels per vector (one class of 8 pixels per ymm). The 4-class
// words of the 8 pixels come from one VPGATHERDD, the classes out of them by VPSLLD / VPSRAD, the
// table entries from VGATHERDPS; the max (VPMAXSD), the float32 sum in class order (VADDPS),
// 1 / sum (VDIVPS) and the products run on 8 pixels at once. The loop nest is
// nn/softmax_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/softmax_i8_simd.h"

namespace ef::nn {
namespace {

struct SoftmaxY8 {
  static constexpr int kPixels = 8;
  using I = __m256i;
  using F = __m256;
  using Offs = __m256i;  // l * C: byte offset of pixel l
  static Offs offsets(int C) { return _mm256_mullo_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32(C)); }
  static I load_words(const int8_t* q, const Offs& o, int c) {
    return _mm256_i32gather_epi32(reinterpret_cast<const int*>(q + c), o, 1);
  }
  static I byte(I w, int k) { return _mm256_srai_epi32(_mm256_sll_epi32(w, _mm_cvtsi32_si128(24 - 8 * k)), 24); }
  static I splat_i(int v) { return _mm256_set1_epi32(v); }
  static I max_i(I a, I b) { return _mm256_max_epi32(a, b); }
  static I sub_i(I a, I b) { return _mm256_sub_epi32(a, b); }
  static void store_i(int32_t* p, I v) { _mm256_store_si256(reinterpret_cast<__m256i*>(p), v); }
  static I load_i(const int32_t* p) { return _mm256_load_si256(reinterpret_cast<const __m256i*>(p)); }
  static F lookup(const float* t, I d) { return _mm256_i32gather_ps(t, d, 4); }
  static F zero_f() { return _mm256_setzero_ps(); }
  static F add_f(F a, F b) { return _mm256_add_ps(a, b); }
  static F recip(F s) { return _mm256_div_ps(_mm256_set1_ps(1.0f), s); }
  static void store_f(float* p, F v) { _mm256_store_ps(p, v); }
};

}  // namespace

void softmax_i8__avx2(const SoftmaxArgs& a) { softmax_pixels<SoftmaxY8, SoftmaxT4>(a); }

}  // namespace ef::nn
