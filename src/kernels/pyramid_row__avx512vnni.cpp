// pyramid_row at the AVX-512 level: 16 coarse pixels per step in zmm registers, masks in k registers
// (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
// A finer row's even and odd columns: two loads and one VPERMT2PS each.
#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_avx512.h"
#include "kernels/pyramid_row_simd.h"

namespace ef::kernels {

namespace {
struct Avx512 : F32Avx512 {
  static void load2(const float* p, F& even, F& odd) {
    const F a = _mm512_loadu_ps(p), b = _mm512_loadu_ps(p + 16);
    const __m512i ie = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    const __m512i io = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    even = _mm512_permutex2var_ps(a, ie, b);
    odd = _mm512_permutex2var_ps(a, io, b);
  }
};
}  // namespace

void pyramid_row__avx512vnni(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  pyramid_row_simd<Avx512>(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
