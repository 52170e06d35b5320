// normal_row at the AVX-512 level: 16 pixels per step in zmm registers, masks in k registers
// (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
// The 48 floats of 16 pixels are three loads; two VPERMT2PS gather each component, and the same in
// reverse to store (F32Avx512::load3 / store3).
#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_avx512.h"
#include "kernels/normal_row_simd.h"

namespace ef::kernels {

void normal_row__avx512vnni(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<F32Avx512>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
