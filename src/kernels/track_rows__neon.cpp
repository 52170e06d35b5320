// track_rows for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes. LD3 de-interleaves the xyz triples; FRINTM is the floor, FCVTZS the truncation,
// FDIV the IEEE division. NEON has no gather: the reference maps are read with one 64-bit (float
// pair) or 32-bit load per lane. Separate FMUL / FADD: AArch64 always has FMLA, and the compiler
// would fuse them if contraction were on, which would change the rounding (this file turns it off).
#include <arm_neon.h>

#include "kernels/track_rows_simd.h"

namespace ef::kernels {

namespace {
struct Neon {
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
  static F add(F a, F b) { return vaddq_f32(a, b); }
  static F sub(F a, F b) { return vsubq_f32(a, b); }
  static F mul(F a, F b) { return vmulq_f32(a, b); }
  static F div(F a, F b) { return vdivq_f32(a, b); }
  static F neg(F a) { return vnegq_f32(a); }
  static F abs(F a) { return vabsq_f32(a); }
  static F floor(F a) { return vrndmq_f32(a); }
  static I cvtt(F a) { return vcvtq_s32_f32(a); }
  static F cvt(I a) { return vcvtq_f32_s32(a); }
  static I iset1(int x) { return vdupq_n_s32(x); }
  static I iadd(I a, I b) { return vaddq_s32(a, b); }
  static I imul(I a, I b) { return vmulq_s32(a, b); }
  static M lt(F a, F b) { return vcltq_f32(a, b); }
  static M le(F a, F b) { return vcleq_f32(a, b); }
  static M gt(F a, F b) { return vcgtq_f32(a, b); }
  static M ge(F a, F b) { return vcgeq_f32(a, b); }
  static M ne(F a, F b) { return vmvnq_u32(vceqq_f32(a, b)); }
  static M land(M a, M b) { return vandq_u32(a, b); }
  static M lor(M a, M b) { return vorrq_u32(a, b); }
  static bool any(M m) { return vmaxvq_u32(m) != 0; }
  static int count(M m) { return static_cast<int>(vaddvq_u32(vshrq_n_u32(m, 31))); }
  static F keep(M m, F a) { return vreinterpretq_f32_u32(vandq_u32(m, vreinterpretq_u32_f32(a))); }
  static F select(M m, F a, F b) { return vbslq_f32(m, a, b); }
  static I ikeep(M m, I a) { return vandq_s32(vreinterpretq_s32_u32(m), a); }
  // One 64-bit load per lane (LD1 of two floats), then UZP1 / UZP2 for the even and the odd floats.
  static void gather2(const float* base, I idx, F& lo, F& hi) {
    const F t0 = vcombine_f32(vld1_f32(base + vgetq_lane_s32(idx, 0)), vld1_f32(base + vgetq_lane_s32(idx, 1)));
    const F t1 = vcombine_f32(vld1_f32(base + vgetq_lane_s32(idx, 2)), vld1_f32(base + vgetq_lane_s32(idx, 3)));
    lo = vuzp1q_f32(t0, t1);
    hi = vuzp2q_f32(t0, t1);
  }
  static F gather(const float* base, I idx) {
    F r = vdupq_n_f32(base[vgetq_lane_s32(idx, 0)]);
    r = vsetq_lane_f32(base[vgetq_lane_s32(idx, 1)], r, 1);
    r = vsetq_lane_f32(base[vgetq_lane_s32(idx, 2)], r, 2);
    return vsetq_lane_f32(base[vgetq_lane_s32(idx, 3)], r, 3);
  }
};
}  // namespace

void track_rows__neon(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                      const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                      TrackRowsCounts* counts) {
  track_rows_simd<Neon>(params, cur_vertex, cur_normal, cur_intensity, n, icp_rows, rgb_rows, stride, counts);
}

}  // namespace ef::kernels
