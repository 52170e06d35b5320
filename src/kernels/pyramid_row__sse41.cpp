// pyramid_row for SSE4.1 (the x86-64 baseline): 4 coarse pixels per step in xmm registers, lane masks
// as all-ones float lanes; a finer row's even and odd columns are two loads and two SHUFPS.
#include <smmintrin.h>

#include <cstdint>

#include "kernels/f32_ops_sse41.h"
#include "kernels/pyramid_row_simd.h"

namespace ef::kernels {

namespace {
struct Sse41 : F32Sse41 {
  static void load2(const float* p, F& even, F& odd) {
    const F a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4);
    even = _mm_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0));
    odd = _mm_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
  }
};
}  // namespace

void pyramid_row__sse41(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  pyramid_row_simd<Sse41>(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
