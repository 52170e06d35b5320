// crf_rows at the AVX-512 level (only F is used; named after the repo's level, see kernels/variants.h):
// one 16-float row is one zmm, so a slice is 7 load-multiply-adds into one register, a splat 7
// read-modify-writes. Separate VMULPS and VADDPS in the reference's order (no FMA); the loops are
// kernels/crf_rows_simd.h.
#include <immintrin.h>

#include "kernels/crf_rows_simd.h"

namespace ef::kernels {

namespace {
struct Z16 {
  using R = __m512;
  static constexpr int kLanes = 16;
  static R zero() { return _mm512_setzero_ps(); }
  static R set1(float x) { return _mm512_set1_ps(x); }
  static R load(const float* p) { return _mm512_loadu_ps(p); }
  static void store(float* p, R v) { _mm512_storeu_ps(p, v); }
  static R add(R a, R b) { return _mm512_add_ps(a, b); }
  static R mul(R a, R b) { return _mm512_mul_ps(a, b); }
  static void prefetch(const float* p) { _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0); }
};
}  // namespace

const CrfRowsKernel crf_rows__avx512vnni = crf_rows_kernel<Z16>();

}  // namespace ef::kernels
