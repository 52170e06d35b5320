// normal_row for AVX2: 8 pixels per step in ymm registers (separate multiply and add: contraction
// off, although the file is built with -mfma). Each half of 4 pixels is de-interleaved (and
// interleaved to store) as the SSE4.1 variant does (kernels/xyz4_sse.h).
#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_avx2.h"
#include "kernels/normal_row_simd.h"
#include "kernels/xyz4_sse.h"

namespace ef::kernels {

namespace {
struct Avx2 : F32Avx2 {
  static void load3(const float* p, F& x, F& y, F& z) {
    __m128 x0, y0, z0, x1, y1, z1;
    load_xyz4(p, x0, y0, z0);
    load_xyz4(p + 12, x1, y1, z1);
    x = _mm256_set_m128(x1, x0);
    y = _mm256_set_m128(y1, y0);
    z = _mm256_set_m128(z1, z0);
  }
  static void store3(float* p, F x, F y, F z) {
    store_xyz4(p, _mm256_castps256_ps128(x), _mm256_castps256_ps128(y), _mm256_castps256_ps128(z));
    store_xyz4(p + 12, _mm256_extractf128_ps(x, 1), _mm256_extractf128_ps(y, 1), _mm256_extractf128_ps(z, 1));
  }
};
}  // namespace

void normal_row__avx2(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Avx2>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
