// dwconv_i8 for NEON (AArch64 baseline): 8 channels per block in two int32x4 accumulators. Per tap
// pair, the 8 input bytes of each tap are sign-extended to int16 (SXTL), the interleaved weights are
// split back into the two taps by one LD2, and SMLAL / SMLAL2 multiply-accumulate into int32;
// requantisation in float as nn/requantize.h, with FCVTNS (round to nearest, ties to even).
#include <arm_neon.h>

#include "nn/dwconv_i8_simd.h"

namespace ef::nn {

namespace {
struct Neon {
  static constexpr int kWidth = 8;
  static constexpr bool kMasked = false;
  struct Acc {
    int32x4_t lo, hi;  // channels 0-3, 4-7
  };
  static Acc load_bias(const int32_t* b) { return {vld1q_s32(b), vld1q_s32(b + 4)}; }
  static Acc mac2(Acc acc, const int8_t* x0, const int8_t* x1, const int16_t* w) {
    const int16x8_t a = vmovl_s8(vld1_s8(x0)), b = vmovl_s8(vld1_s8(x1));
    const int16x8x2_t wt = vld2q_s16(w);  // val[0]: first tap of the pair, val[1]: second
    acc.lo = vmlal_s16(acc.lo, vget_low_s16(a), vget_low_s16(wt.val[0]));
    acc.hi = vmlal_high_s16(acc.hi, a, wt.val[0]);
    acc.lo = vmlal_s16(acc.lo, vget_low_s16(b), vget_low_s16(wt.val[1]));
    acc.hi = vmlal_high_s16(acc.hi, b, wt.val[1]);
    return acc;
  }
  static int32x4_t requant4(int32x4_t acc, const float* m, const DwRequant& rq) {
    float32x4_t y = vmulq_f32(vcvtq_f32_s32(acc), vld1q_f32(m));
    y = vminq_f32(vmaxq_f32(y, vdupq_n_f32(rq.y_lo)), vdupq_n_f32(rq.y_hi));
    return vaddq_s32(vcvtnq_s32_f32(y), vdupq_n_s32(rq.zp));
  }
  static void store(Acc acc, const float* m, const DwRequant& rq, int8_t* dst) {
    // In range after the clamp, so the saturating narrows only narrow.
    const int16x8_t q16 = vcombine_s16(vqmovn_s32(requant4(acc.lo, m, rq)), vqmovn_s32(requant4(acc.hi, m + 4, rq)));
    vst1_s8(dst, vqmovn_s16(q16));
  }
};

std::size_t packed_bytes(const ConvShape& shape) { return dw_packed_bytes(shape); }
void pack(const ConvShape& shape, const ConvParams& params, void* dst) { dw_pack(shape, params, dst); }
void run(const ConvArgs& a) { dw_run<Neon>(a); }
}  // namespace

const ConvKernel dwconv_i8__neon = {packed_bytes, pack, run};

}  // namespace ef::nn
