// fusion_gates for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes. LD4 de-interleaves the 4-float surfaces; FRINTP is the ceiling. Separate FMUL / FADD
// (this file turns contraction off, as every kernel).
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/fusion_gates_simd.h"

namespace ef::kernels {

namespace {
struct Neon : F32Neon {
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
  static I set_bits(I c, M m, uint32_t bits) {
    return vorrq_s32(c, vreinterpretq_s32_u32(vandq_u32(m, vdupq_n_u32(bits))));
  }
};
}  // namespace

void fusion_gates__neon(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  fusion_gates_simd<Neon>(p, row, x_begin, x_end, code);
}

}  // namespace ef::kernels
