// fusion_gates for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes. LD4 de-interleaves the 4-float surfaces; FRINTP is the ceiling. Separate FMUL / FADD
// (this file turns contraction off, as every kernel).
#include <arm_neon.h>

#include "kernels/fusion_gates_simd.h"

namespace ef::kernels {

namespace {
struct Neon {
  using F = float32x4_t;
  using I = int32x4_t;
  using M = uint32x4_t;
  static constexpr int kWidth = 4;
  static F set1(float x) { return vdupq_n_f32(x); }
  static F load(const float* p) { return vld1q_f32(p); }
  static I iset1(int x) { return vdupq_n_s32(x); }
  static I iload(const int32_t* p) { return vld1q_s32(p); }
  static void istore(uint32_t* p, I x) { vst1q_u32(p, vreinterpretq_u32_s32(x)); }
  static I iota() {
    static const int32_t k[4] = {0, 1, 2, 3};
    return vld1q_s32(k);
  }
  static void load_surfaces(const float* p, F& x, F& y, F& z) {
    const float32x4x4_t v = vld4q_f32(p);
    x = v.val[0];
    y = v.val[1];
    z = v.val[2];
  }
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F abs(F a) { return vabsq_f32(a); }
  static F ceil(F a) { return vrndpq_f32(a); }
  static F cvt(I a) { return vcvtq_f32_s32(a); }
  static M lt(F a, F b) { return vcltq_f32(a, b); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static M eq(F a, F b) { return vceqq_f32(a, b); }
  static M igt(I a, I b) { return vcgtq_s32(a, b); }
  static I iadd(I a, I b) { return vaddq_s32(a, b); }
  static M land(M a, M b) { return vandq_u32(a, b); }
  static M lor(M a, M b) { return vorrq_u32(a, b); }
  static M lnot(M a) { return vmvnq_u32(a); }
  static I set_bits(I c, M m, uint32_t bits) {
    return vorrq_s32(c, vreinterpretq_s32_u32(vandq_u32(m, vdupq_n_u32(bits))));
  }
};
}  // namespace

void fusion_gates__neon(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  fusion_gates_simd<Neon>(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
