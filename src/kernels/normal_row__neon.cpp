// normal_row for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes; LD3 / ST3 de-interleave and interleave the three components. Separate FMUL / FADD
// (this file turns contraction off, as every kernel); FDIV and FSQRT are the IEEE operations.
#include <arm_neon.h>

#include "kernels/normal_row_simd.h"

namespace ef::kernels {

namespace {
struct Neon {
  using F = float32x4_t;
  using M = uint32x4_t;
  static constexpr int kWidth = 4;
  static F set1(float x) { return vdupq_n_f32(x); }
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
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F div(F a, F b) { return vdivq_f32(a, b); }
  static F sqrt(F a) { return vsqrtq_f32(a); }
  static F abs(F a) { return vabsq_f32(a); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static M le(F a, F b) { return vcleq_f32(a, b); }
  static M land(M a, M b) { return vandq_u32(a, b); }
  static F select(M m, F a, F b) { return vbslq_f32(m, a, b); }
};
}  // namespace

void normal_row__neon(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Neon>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
