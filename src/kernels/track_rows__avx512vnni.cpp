// track_rows at the AVX-512 level: 16 pixels per step in zmm registers, lane masks in k registers
// (AVX-512 F/DQ; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
// The reference maps are read with gathers: VGATHERDPD of float pairs (the two bilinear taps of an
// image row, x and y of a vertex or normal) and VGATHERDPS for single floats; xyz triples of the
// current frame are de-interleaved with two VPERMT2PS per component (F32Avx512::load3).
#include <immintrin.h>

#include "kernels/f32_ops_avx512.h"
#include "kernels/track_rows_simd.h"

namespace ef::kernels {

namespace {
struct Avx512 : F32Avx512 {
  static F gather(const float* base, I idx) { return _mm512_mask_i32gather_ps(zero(), kAll, idx, base, 4); }
  // Two VGATHERDPD of 8 float pairs, then the even and the odd floats of the 16 pairs.
  static void gather2(const float* base, I idx, F& lo, F& hi) {
    const __m512d none = _mm512_setzero_pd();
    const F g0 = _mm512_castpd_ps(
        _mm512_mask_i32gather_pd(none, static_cast<__mmask8>(0xFF),
                                 _mm512_maskz_extracti64x4_epi64(static_cast<__mmask8>(0xFF), idx, 0), base, 4));
    const F g1 = _mm512_castpd_ps(
        _mm512_mask_i32gather_pd(none, static_cast<__mmask8>(0xFF),
                                 _mm512_maskz_extracti64x4_epi64(static_cast<__mmask8>(0xFF), idx, 1), base, 4));
    const I even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    const I odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    lo = _mm512_permutex2var_ps(g0, even, g1);
    hi = _mm512_permutex2var_ps(g0, odd, g1);
  }
};
}  // namespace

void track_rows__avx512vnni(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                            const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows,
                            std::size_t stride, TrackRowsCounts* counts) {
  track_rows_simd<Avx512>(params, cur_vertex, cur_normal, cur_intensity, n, icp_rows, rgb_rows, stride, counts);
}

}  // namespace ef::kernels
