// reduce_normal_equations at the AVX-512 level: still 8-lane ymm registers (a zmm would put two rows
// of one lane in different halves and change the summation order), but AVX-512VL gives 32 of them,
// so the 28 outputs take two passes of 14 accumulators instead of four: each input is loaded about
// half as often as in the AVX2 variant. Its vector ops are the AVX2 ones (kernels/f32_ops_avx2.h);
// only the widening into the double totals uses AVX-512. Separate multiply and add (contraction off).
#include <immintrin.h>

#include "kernels/f32_ops_avx2.h"
#include "kernels/reduce_normal_equations_simd.h"

namespace ef::kernels {

namespace {
struct Avx512Ymm : F32Avx2 {
  static void add_to_totals(double* t, F v) {
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
