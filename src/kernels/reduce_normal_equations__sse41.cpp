// reduce_normal_equations for SSE4.1 (x86-64 baseline): 4 lanes per xmm, so each of the 8 lanes of
// the specification is visited in two halves; four passes of at most 7 accumulators fit the 16 xmm
// registers. Products and sums are separate MULPS / ADDPS (contraction off), as the reference.
#include <smmintrin.h>

#include "kernels/f32_ops_sse41.h"
#include "kernels/reduce_normal_equations_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 : F32Sse41 {
  static void add_to_totals(double* t, F v) {
    _mm_storeu_pd(t, _mm_add_pd(_mm_loadu_pd(t), _mm_cvtps_pd(v)));
    _mm_storeu_pd(t + 2, _mm_add_pd(_mm_loadu_pd(t + 2), _mm_cvtps_pd(_mm_movehl_ps(v, v))));
  }
};
}  // namespace

void reduce_normal_equations__sse41(const float* rows, std::size_t stride, std::size_t n, NormalEquations* out) {
  ne_reduce_simd<Sse41, NePass<Sse41, 0>, NePass<Sse41, 1, 6>, NePass<Sse41, 2, 5>, NePass<Sse41, 3, 4>>(rows, stride,
                                                                                                      n, out);
}

}  // namespace ef::kernels
