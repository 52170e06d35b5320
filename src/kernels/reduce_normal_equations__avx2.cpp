// reduce_normal_equations for AVX2: one ymm holds the 8 lanes of an output; four passes of at most
// 7 accumulators fit the 16 ymm registers. Separate VMULPS / VADDPS: this file is compiled with -mfma
// (the AVX2 level) but with contraction off, so no FMA is formed and sums match the reference.
#include <immintrin.h>

#include "kernels/f32_ops_avx2.h"
#include "kernels/reduce_normal_equations_simd.h"

namespace ef::kernels {

namespace {
struct Avx2 : F32Avx2 {
  static void add_to_totals(double* t, F v) {
    _mm256_storeu_pd(t, _mm256_add_pd(_mm256_loadu_pd(t), _mm256_cvtps_pd(_mm256_castps256_ps128(v))));
    _mm256_storeu_pd(t + 4, _mm256_add_pd(_mm256_loadu_pd(t + 4), _mm256_cvtps_pd(_mm256_extractf128_ps(v, 1))));
  }
};
}  // namespace

void reduce_normal_equations__avx2(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  ne_reduce_simd<Avx2, NePass<Avx2, 0>, NePass<Avx2, 1, 6>, NePass<Avx2, 2, 5>, NePass<Avx2, 3, 4>>(rows, stride, n,
                                                                                                  out);
}

}  // namespace ef::kernels
