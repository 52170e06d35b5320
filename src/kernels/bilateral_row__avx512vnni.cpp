// bilateral_row at the AVX-512 level: 16 output pixels per step in zmm registers, the output mask in
// a k register (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see
// kernels/variants.h).
#include <immintrin.h>

#include "kernels/bilateral_row_simd.h"
#include "kernels/f32_ops_avx512.h"

namespace ef::kernels {

void bilateral_row__avx512vnni(const BilateralRow& b, int width, float* out) {
  bilateral_row_simd<F32Avx512>(b, width, out);
}

}  // namespace ef::kernels
