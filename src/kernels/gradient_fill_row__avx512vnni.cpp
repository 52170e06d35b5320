// gradient_fill_row at the AVX-512 level: 16 pixels per step in zmm registers, masks in k registers
// (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
#include <immintrin.h>

#include "kernels/f32_ops_avx512.h"
#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

void gradient_fill_row__avx512vnni(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                                   float* filled) {
  gradient_fill_row_simd<F32Avx512>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
