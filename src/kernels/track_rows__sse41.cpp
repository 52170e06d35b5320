// track_rows for SSE4.1 (x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes, ROUNDPS for the floor, PMULLD for pixel offsets. SSE has no gather: the
// reference maps are read with one 64-bit (float pair) or 32-bit load per lane. xyz triples are
// de-interleaved with two blends and one shuffle per component (F32Sse41::load3).
#include <smmintrin.h>

#include "kernels/f32_ops_sse41.h"
#include "kernels/track_rows_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 : F32Sse41 {
  // One 64-bit load per lane (MOVLPS / MOVHPS), then the even and the odd floats.
  static void gather2(const float* base, I idx, F& lo, F& hi) {
    const auto at = [base](int i) { return reinterpret_cast<const __m64*>(base + i); };
    const F t0 =
        _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), at(_mm_cvtsi128_si32(idx))), at(_mm_extract_epi32(idx, 1)));
    const F t1 =
        _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), at(_mm_extract_epi32(idx, 2))), at(_mm_extract_epi32(idx, 3)));
    lo = _mm_shuffle_ps(t0, t1, _MM_SHUFFLE(2, 0, 2, 0));
    hi = _mm_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 1, 3, 1));
  }
  static F gather(const float* base, I idx) {
    return _mm_setr_ps(base[_mm_cvtsi128_si32(idx)], base[_mm_extract_epi32(idx, 1)], base[_mm_extract_epi32(idx, 2)],
                       base[_mm_extract_epi32(idx, 3)]);
  }
};
}  // namespace

void track_rows__sse41(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                       const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                       TrackRowsCounts* counts) {
  track_rows_simd<Sse41>(params, cur_vertex, cur_normal, cur_intensity, n, icp_rows, rgb_rows, stride, counts);
}

}  // namespace ef::kernels
