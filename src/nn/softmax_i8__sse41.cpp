// softmax_i8 at the SSE4.1 level: 4 pixels per vector (one class of 4 pixels per register). SSE4.1
// has no gathers: the 4-class words of the 4 pixels (MOVD, PINSRD) and the table entries (MOVSS,
// INSERTPS) are scalar loads put together into vectors; the class bytes (PSLLD, PSRAD), the max
// (PMAXSD), the float32 sum in class order (ADDPS), 1 / sum (DIVPS) and the products (MULPS) run on
// the 4 pixels at once. The loop nest is nn/softmax_i8_simd.h.
#include <cstring>

#include "nn/eltwise_kernels.h"
#include "nn/softmax_i8_simd.h"

namespace ef::nn {
namespace {

struct SoftmaxX4 {
  static constexpr int kPixels = 4;
  using I = __m128i;
  using F = __m128;
  using Offs = int;  // C: the byte stride from one pixel to the next
  static Offs offsets(int C) { return C; }
  static int32_t word(const int8_t* p) {
    int32_t w;
    std::memcpy(&w, p, 4);
    return w;
  }
  static I load_words(const int8_t* q, Offs C, int c) {
    return _mm_setr_epi32(word(q + c), word(q + C + c), word(q + 2 * C + c), word(q + 3 * C + c));
  }
  static I byte(I w, int k) { return _mm_srai_epi32(_mm_sll_epi32(w, _mm_cvtsi32_si128(24 - 8 * k)), 24); }
  static I splat_i(int v) { return _mm_set1_epi32(v); }
  static I max_i(I a, I b) { return _mm_max_epi32(a, b); }
  static I sub_i(I a, I b) { return _mm_sub_epi32(a, b); }
  static void store_i(int32_t* p, I v) { _mm_store_si128(reinterpret_cast<__m128i*>(p), v); }
  static I load_i(const int32_t* p) { return _mm_load_si128(reinterpret_cast<const __m128i*>(p)); }
  static F lookup(const float* t, I d) {
    return _mm_setr_ps(t[_mm_cvtsi128_si32(d)], t[_mm_extract_epi32(d, 1)], t[_mm_extract_epi32(d, 2)],
                       t[_mm_extract_epi32(d, 3)]);
  }
  static F zero_f() { return _mm_setzero_ps(); }
  static F add_f(F a, F b) { return _mm_add_ps(a, b); }
  static F recip(F s) { return _mm_div_ps(_mm_set1_ps(1.0f), s); }
  static void store_f(float* p, F v) { _mm_store_ps(p, v); }
};

}  // namespace

void softmax_i8__sse41(const SoftmaxArgs& a) { softmax_pixels<SoftmaxX4, SoftmaxT4>(a); }

}  // namespace ef::nn
