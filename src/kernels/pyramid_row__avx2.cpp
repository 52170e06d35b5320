// pyramid_row for AVX2: 8 coarse pixels per step in ymm registers (separate multiply and add:
// contraction off, although the file is built with -mfma). A finer row's even and odd columns: two
// loads, SHUFPS within each 128-bit half, then VPERMPD to put the halves' pairs in order.
#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_avx2.h"
#include "kernels/pyramid_row_simd.h"

namespace ef::kernels {

namespace {
struct Avx2 : F32Avx2 {
  static void load2(const float* p, F& even, F& odd) {
    const F a = _mm256_loadu_ps(p), b = _mm256_loadu_ps(p + 8);
    // Per half: p0 p2 p8 p10 | p4 p6 p12 p14; 64-bit pairs 0 2 1 3 give p0 p2 p4 ... p14.
    const F e = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0)), o = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
    even = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(e), _MM_SHUFFLE(3, 1, 2, 0)));
    odd = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(o), _MM_SHUFFLE(3, 1, 2, 0)));
  }
};
}  // namespace

void pyramid_row__avx2(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  pyramid_row_simd<Avx2>(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
