// track_rows for AVX2: 8 pixels per step in ymm registers, lane masks as all-ones float lanes. The
// reference maps are read with gathers (VGATHERDPD of float pairs, VGATHERDPS of single floats); xyz
// triples are de-interleaved with two blends and one VPERMPS per component (F32Avx2::load3). Separate multiply and add
// (contraction off; the file is built with -mfma).
#include <immintrin.h>

#include "kernels/f32_ops_avx2.h"
#include "kernels/track_rows_simd.h"

namespace ef::kernels {

namespace {
struct Avx2 : F32Avx2 {
  static F gather(const float* base, I idx) { return _mm256_i32gather_ps(base, idx, 4); }
  // Two VGATHERDPD of 4 float pairs: [a0 b0 a1 b1 | a2 b2 a3 b3] and [a4 b4 .. | ..]; a SHUFPS picks
  // the even (odd) floats per 128-bit half, a VPERMPD puts the halves in order.
  static void gather2(const float* base, I idx, F& lo, F& hi) {
    const double* b = reinterpret_cast<const double*>(base);
    const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi32(-1));
    const __m256d none = _mm256_setzero_pd();
    const F g0 = _mm256_castpd_ps(_mm256_mask_i32gather_pd(none, b, _mm256_castsi256_si128(idx), all, 4));
    const F g1 = _mm256_castpd_ps(_mm256_mask_i32gather_pd(none, b, _mm256_extracti128_si256(idx, 1), all, 4));
    lo = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, _MM_SHUFFLE(2, 0, 2, 0))),
                                                _MM_SHUFFLE(3, 1, 2, 0)));
    hi = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, _MM_SHUFFLE(3, 1, 3, 1))),
                                                _MM_SHUFFLE(3, 1, 2, 0)));
  }
};
}  // namespace

void track_rows__avx2(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                      const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                      TrackRowsCounts* counts) {
  track_rows_simd<Avx2>(params, cur_vertex, cur_normal, cur_intensity, n, icp_rows, rgb_rows, stride, counts);
}

}  // namespace ef::kernels
