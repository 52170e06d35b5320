// track_rows for NEON (AArch64 baseline): 4 pixels per step in q registers, lane masks as all-ones
// uint32 lanes. LD3 de-interleaves the xyz triples; FRINTM is the floor, FCVTZS the truncation,
// FDIV the IEEE division. NEON has no gather: the reference maps are read with one 64-bit (float
// pair) or 32-bit load per lane. Separate FMUL / FADD: AArch64 always has FMLA, and the compiler
// would fuse them if contraction were on, which would change the rounding (this file turns it off).
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/track_rows_simd.h"

namespace ef::kernels {

namespace {
struct Neon : F32Neon {
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
