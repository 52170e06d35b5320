// crf_rows for AVX2: one 16-float row is two ymm, separate VMULPS and VADDPS in the reference's order
// (no FMA, although this level has it); the loops are kernels/crf_rows_simd.h.
#include <immintrin.h>

#include "kernels/crf_rows_simd.h"

namespace ef::kernels {

namespace {
struct Y8 {
  using R = __m256;
  static constexpr int kLanes = 8;
  static R zero() { return _mm256_setzero_ps(); }
  static R set1(float x) { return _mm256_set1_ps(x); }
  static R load(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, R v) { _mm256_storeu_ps(p, v); }
  static R add(R a, R b) { return _mm256_add_ps(a, b); }
  static R mul(R a, R b) { return _mm256_mul_ps(a, b); }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }
};
}  // namespace

const CrfRowsKernel crf_rows__avx2 = crf_rows_kernel<Y8>();

}  // namespace ef::kernels
