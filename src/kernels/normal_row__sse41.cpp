// normal_row for SSE4.1 (the x86-64 baseline): 4 pixels per step in xmm registers, lane masks as
// all-ones float lanes. Three components of four pixels are three loads, de-interleaved (and
// interleaved to store) by kernels/xyz4_sse.h.
#include <smmintrin.h>

#include <cstdint>

#include "kernels/f32_ops_sse41.h"
#include "kernels/normal_row_simd.h"
#include "kernels/xyz4_sse.h"

namespace ef::kernels {

namespace {
struct Sse41 : F32Sse41 {
  static void load3(const float* p, F& x, F& y, F& z) { load_xyz4(p, x, y, z); }
  static void store3(float* p, F x, F y, F z) { store_xyz4(p, x, y, z); }
};
}  // namespace

void normal_row__sse41(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Sse41>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
