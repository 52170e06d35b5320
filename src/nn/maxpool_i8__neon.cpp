// maxpool_i8 on NEON: NHWC, vectorised over channels, 16 per SMAX q, 8 per SMAX d, the rest one at
// a time; the loop nest is nn/maxpool_i8_simd.h.
#include <arm_neon.h>

#include "nn/eltwise_kernels.h"
#include "nn/maxpool_i8_simd.h"

namespace ef::nn {
namespace {

struct Q16 {
  using R = int8x16_t;
  static constexpr int kLanes = 16;
  static R lowest() { return vdupq_n_s8(-128); }
  static R load(const int8_t* p) { return vld1q_s8(p); }
  static R max(R a, R b) { return vmaxq_s8(a, b); }
  static void store(int8_t* p, R v) { vst1q_s8(p, v); }
};
struct D8 {
  using R = int8x8_t;
  static constexpr int kLanes = 8;
  static R lowest() { return vdup_n_s8(-128); }
  static R load(const int8_t* p) { return vld1_s8(p); }
  static R max(R a, R b) { return vmax_s8(a, b); }
  static void store(int8_t* p, R v) { vst1_s8(p, v); }
};

}  // namespace

void maxpool_i8__neon(const PoolArgs& a) { maxpool_rows<PoolChannels<Q16, D8>>(a); }

}  // namespace ef::nn
