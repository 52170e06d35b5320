// normal_row for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes; LD3 / ST3 de-interleave and interleave the three components. Separate FMUL / FADD
// (this file turns contraction off, as every kernel); FDIV and FSQRT are the IEEE operations.
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/normal_row_simd.h"

namespace ef::kernels {

namespace {
struct Neon : F32Neon {
  static void load3(const float* p, F& x, F& y, F& z) {
    const float32x4x3_t v = vld3q_f32(p);
    x = v.val[0];
    y = v.val[1];
    z = v.val[2];
  }
  static void store3(float* p, F x, F y, F z) {
    float32x4x3_t v;
    v.val[0] = x;
    v.val[1] = y;
    v.val[2] = z;
    vst3q_f32(p, v);
  }
};
}  // namespace

void normal_row__neon(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Neon>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
