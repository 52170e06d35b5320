// What the two AArch64 conv_i8 variants share: the requantising store of one panel of 4 output
// channels (nn/requantize.h on NEON) and of a finished tile. Internal linkage (the rule in kernels/variants.h).
#pragma once

#include <arm_neon.h>

#include <cstdint>

#include "nn/conv_i8_simd.h"

namespace ef::nn {
namespace {

// float(acc) * m (FCVT from int32 rounds to nearest even, as CVTDQ2PS), clamp to [lo - zp, hi - zp],
// FCVTNS (round half to even), + zp, narrow (exact: within [-128, 127]); stores `valid` (1..4) bytes.
inline void store_requantized_neon(int32x4_t acc, const float* mult, int32_t zp, int32_t lo, int32_t hi, int8_t* dst,
                                   int valid) {
  float32x4_t f = vmulq_f32(vcvtq_f32_s32(acc), vld1q_f32(mult));
  f = vminq_f32(vmaxq_f32(f, vdupq_n_f32(float(lo - zp))), vdupq_n_f32(float(hi - zp)));
  const int32x4_t q = vaddq_s32(vcvtnq_s32_f32(f), vdupq_n_s32(zp));
  const int16x4_t q16 = vqmovn_s32(q);
  const int8x8_t q8 = vqmovn_s16(vcombine_s16(q16, q16));
  if (valid == 4) {
    vst1_lane_s32(reinterpret_cast<int32_t*>(dst), vreinterpret_s32_s8(q8), 0);
  } else {
    int8_t tmp[8];
    vst1_s8(tmp, q8);
    for (int i = 0; i < valid; ++i) dst[i] = tmp[i];
  }
}

// Requantises and stores a finished MR x NV tile of 4-channel panels (pixels past j.npix skipped).
template <int NV, int MR>
inline void store_tile_neon(const TileJob& j, const int32x4_t (&acc)[MR][NV]) {
  const ConvArgs& a = *j.a;
  const ConvPackHeader& h = conv_header(j.blob);
  const float* mult = conv_mult(j.blob) + j.panel0 * 4;
  for (int v = 0; v < NV; ++v) {
    const int c0 = (j.panel0 + v) * 4;
    const int valid = h.cout - c0 < 4 ? h.cout - c0 : 4;
    for (int m = 0; m < MR && m < j.npix; ++m) {
      int8_t* dst = a.out.data + (std::ptrdiff_t(j.oy) * a.out.w + j.ox0 + m) * a.out.c + c0;
      store_requantized_neon(acc[m][v], mult + 4 * v, a.out.zero_point, a.out_min, a.out_max, dst, valid);
    }
  }
}

}  // namespace
}  // namespace ef::nn
