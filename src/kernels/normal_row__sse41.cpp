// normal_row for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes. Three components of four pixels are three loads, de-interleaved (and
// interleaved to store) by F32Sse41::load3 / store3 (kernels/f32_ops_sse41.h).
#include <smmintrin.h>

#include <cstdint>

#include "kernels/f32_ops_sse41.h"
#include "kernels/normal_row_simd.h"

namespace ef::kernels {

void normal_row__sse41(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<F32Sse41>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
