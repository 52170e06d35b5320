// Internal to the NEON variants of the kernels written over a vector-ops type (bilateral_row,
// fusion_gates, track_rows, crf_rows, reduce_normal_equations, pyramid_row, normal_row,
// gradient_fill_row): the float and int32 operations they share, 4 lanes in q registers, lane masks
// as all-ones uint32 lanes. Separate FMUL / FADD (the kernel files turn contraction off); FDIV and
// FSQRT are the IEEE operations; selects by BSL; LD3 / ST3 de-interleave and interleave xyz triples
// (load3 / store3, for normal_row and track_rows). Each family's type derives from it (or is it) and
// adds its own loads. Internal linkage (an anonymous namespace): the rule for ISA files in
// kernels/variants.h.
#pragma once

#include <arm_neon.h>

namespace ef::kernels {
namespace {

struct F32Neon {
  using F = float32x4_t;
  using I = int32x4_t;
  using M = uint32x4_t;
  static constexpr int kWidth = 4;
  static F set1(float x) { return vdupq_n_f32(x); }
  static F zero() { return vdupq_n_f32(0.0f); }
  static F load(const float* p) { return vld1q_f32(p); }
  static void store(float* p, F x) { vst1q_f32(p, x); }
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
  static void prefetch(const float* p) { __builtin_prefetch(p); }  // read hint
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F div(F a, F b) { return vdivq_f32(a, b); }
  static F sqrt(F a) { return vsqrtq_f32(a); }
  static F neg(F a) { return vnegq_f32(a); }
  static F abs(F a) { return vabsq_f32(a); }
  static F floor(F a) { return vrndmq_f32(a); }
  static F ceil(F a) { return vrndpq_f32(a); }
  static I cvtt(F a) { return vcvtq_s32_f32(a); }  // toward zero
  static F cvt(I a) { return vcvtq_f32_s32(a); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static M ge(F a, F b) { return vcgeq_f32(a, b); }
  static M lt(F a, F b) { return vcltq_f32(a, b); }
  static M le(F a, F b) { return vcleq_f32(a, b); }
  static M eq(F a, F b) { return vceqq_f32(a, b); }
  static M ne(F a, F b) { return vmvnq_u32(vceqq_f32(a, b)); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return vandq_u32(a, b); }
  static M lor(M a, M b) { return vorrq_u32(a, b); }
  static M lnot(M a) { return vmvnq_u32(a); }
  static bool any(M m) { return vmaxvq_u32(m) != 0; }
  static int count(M m) { return static_cast<int>(vaddvq_u32(vshrq_n_u32(m, 31))); }
  // a where m, else 0
  static F keep(M m, F a) { return vreinterpretq_f32_u32(vandq_u32(m, vreinterpretq_u32_f32(a))); }
  static F select(M m, F a, F b) { return vbslq_f32(m, a, b); }  // a where m, else b
  static I iset1(int x) { return vdupq_n_s32(x); }
  static I iadd(I a, I b) { return vaddq_s32(a, b); }
  static I imul(I a, I b) { return vmulq_s32(a, b); }
  static M igt(I a, I b) { return vcgtq_s32(a, b); }
  static I ikeep(M m, I a) { return vandq_s32(vreinterpretq_s32_u32(m), a); }
};

}  // namespace
}  // namespace ef::kernels
