// normal_row for AVX2: 8 pixels per step in ymm registers (separate multiply and add: contraction
// off, although the file is built with -mfma). xyz triples are read with two blends and one VPERMPS
// per component and written as the SSE4.1 variant does, per half (F32Avx2::load3 / store3).
#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_avx2.h"
#include "kernels/normal_row_simd.h"

namespace ef::kernels {

void normal_row__avx2(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<F32Avx2>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
