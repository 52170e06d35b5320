// reduce_normal_equations at the AVX-512 level: still 8-lane ymm registers (a zmm would put two rows
// of one lane in different halves and change the summation order), but AVX-512VL gives 32 of them,
// so the 28 outputs take two passes of 14 accumulators instead of four: each input is loaded about
// half as often as in the AVX2 variant. Separate multiply and add (contraction off).
#include <immintrin.h>

#include "kernels/reduce_normal_equations_simd.h"

namespace ef::kernels {

namespace {
struct Avx512Ymm {
  using Reg = __m256;
  static constexpr int kWidth = 8;
  static Reg zero() { return _mm256_setzero_ps(); }
  static Reg load(const float* p) { return _mm256_loadu_ps(p); }
  static Reg mul(Reg a, Reg b) { return _mm256_mul_ps(a, b); }
  static Reg add(Reg a, Reg b) { return _mm256_add_ps(a, b); }
  static void add_to_totals(double* t, Reg v) {
    // 8 floats -> 8 doubles, exact. The maskz form with an all-ones mask avoids GCC 12's false
    // -Wmaybe-uninitialized in the plain intrinsic (it merges into _mm512_undefined_pd()).
    const __m512d d = _mm512_maskz_cvtps_pd(static_cast<__mmask8>(0xFF), v);
    _mm512_storeu_pd(t, _mm512_add_pd(_mm512_loadu_pd(t), d));
  }
};
}  // namespace

void reduce_normal_equations__avx512vnni(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  ne_reduce_simd<Avx512Ymm, NePass<Avx512Ymm, 0, 1, 6>, NePass<Avx512Ymm, 2, 3, 4, 5>>(rows, stride, n, out);
}

}  // namespace ef::kernels
