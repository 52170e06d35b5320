// pyramid_row for NEON (AArch64 baseline): 4 coarse pixels per step in q registers, lane masks as
// all-ones uint32 lanes; LD2 de-interleaves a finer row's even and odd columns. Separate FMUL / FADD
// (this file turns contraction off, as every kernel); selects by BSL (FMIN's NaN and signed-zero rules
// are not C++'s conditional, so the minimum is a compare and a select as in the reference).
#include <arm_neon.h>

#include "kernels/pyramid_row_simd.h"

namespace ef::kernels {

namespace {
struct Neon {
  using F = float32x4_t;
  using M = uint32x4_t;
  static constexpr int kWidth = 4;
  static F set1(float x) { return vdupq_n_f32(x); }
  static void store(float* p, F x) { vst1q_f32(p, x); }
  static void load2(const float* p, F& even, F& odd) {
    const float32x4x2_t v = vld2q_f32(p);
    even = v.val[0];
    odd = v.val[1];
  }
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F div(F a, F b) { return vdivq_f32(a, b); }
  static F abs(F a) { return vabsq_f32(a); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static M lt(F a, F b) { return vcltq_f32(a, b); }
  static M le(F a, F b) { return vcleq_f32(a, b); }
  static M ne(F a, F b) { return vmvnq_u32(vceqq_f32(a, b)); }
  static M land(M a, M b) { return vandq_u32(a, b); }
  static F select(M m, F a, F b) { return vbslq_f32(m, a, b); }
};
}  // namespace

void pyramid_row__neon(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  pyramid_row_simd<Neon>(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
