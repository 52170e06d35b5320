// crf_rows for SSE4.1 (the x86-64 baseline): one 16-float row is four xmm, separate MULPS and ADDPS
// in the reference's order; the loops are kernels/crf_rows_simd.h.
#include <smmintrin.h>

#include "kernels/crf_rows_simd.h"

namespace ef::kernels {

namespace {
struct X4 {
  using R = __m128;
  static constexpr int kLanes = 4;
  static R zero() { return _mm_setzero_ps(); }
  static R set1(float x) { return _mm_set1_ps(x); }
  static R load(const float* p) { return _mm_loadu_ps(p); }
  static void store(float* p, R v) { _mm_storeu_ps(p, v); }
  static R add(R a, R b) { return _mm_add_ps(a, b); }
  static R mul(R a, R b) { return _mm_mul_ps(a, b); }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }
};
}  // namespace

const CrfRowsKernel crf_rows__sse41 = crf_rows_kernel<X4>();

}  // namespace ef::kernels
