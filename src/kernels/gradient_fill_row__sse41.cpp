// gradient_fill_row for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane
// masks as all-ones float lanes.
#include <smmintrin.h>

#include "kernels/f32_ops_sse41.h"
#include "kernels/gradient_fill_row_simd.h"

namespace ef::kernels {

void gradient_fill_row__sse41(const GradientFillRow& r, int x_begin, int x_end, float* grad_x, float* grad_y,
                              float* filled) {
  gradient_fill_row_simd<F32Sse41>(r, x_begin, x_end, grad_x, grad_y, filled);
}

}  // namespace ef::kernels
