// Internal to the NEON variants of the row kernels written over a vector-ops type (pyramid_row,
// normal_row, gradient_fill_row): the float operations they share, 4 lanes in q registers, lane masks
// as all-ones uint32 lanes. Separate FMUL / FADD (the kernel files turn contraction off); FDIV and
// FSQRT are the IEEE operations; selects by BSL. Each family's type derives from it and adds its own
// loads. Internal linkage (an anonymous namespace): the rule for ISA files in kernels/variants.h.
#pragma once

#include <arm_neon.h>

namespace ef::kernels {
namespace {

struct F32Neon {
  using F = float32x4_t;
  using M = uint32x4_t;
  static constexpr int kWidth = 4;
  static F set1(float x) { return vdupq_n_f32(x); }
  static F load(const float* p) { return vld1q_f32(p); }
  static void store(float* p, F x) { vst1q_f32(p, x); }
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F div(F a, F b) { return vdivq_f32(a, b); }
  static F sqrt(F a) { return vsqrtq_f32(a); }
  static F abs(F a) { return vabsq_f32(a); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static M lt(F a, F b) { return vcltq_f32(a, b); }
  static M le(F a, F b) { return vcleq_f32(a, b); }
  static M ne(F a, F b) { return vmvnq_u32(vceqq_f32(a, b)); }  // true on NaN, as C++'s !=
  static M land(M a, M b) { return vandq_u32(a, b); }
  static F select(M m, F a, F b) { return vbslq_f32(m, a, b); }  // a where m, else b
};

}  // namespace
}  // namespace ef::kernels
