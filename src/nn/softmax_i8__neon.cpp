// softmax_i8 on NEON: 4 pixels per vector (one class of 4 pixels per q register). NEON has no
// gathers: the 4-class words of the 4 pixels and the table entries are scalar loads put together
// into vectors (LD1 lane); the class bytes (SSHL, SSHR), the max (SMAX), the float32 sum in class
// order (FADD), 1 / sum (FDIV) and the products (FMUL) run on the 4 pixels at once. The loop nest is
// nn/softmax_i8_simd.h.
#include <cstring>

#include "nn/eltwise_kernels.h"
#include "nn/softmax_i8_simd.h"

namespace ef::nn {
namespace {

struct SoftmaxN4 {
  static constexpr int kPixels = 4;
  using I = int32x4_t;
  using F = float32x4_t;
  using Offs = int;  // C: the byte stride from one pixel to the next
  static Offs offsets(int C) { return C; }
  static int32_t word(const int8_t* p) {
    int32_t w;
    std::memcpy(&w, p, 4);
    return w;
  }
  static I load_words(const int8_t* q, Offs C, int c) {
    I v = vdupq_n_s32(word(q + c));
    v = vsetq_lane_s32(word(q + C + c), v, 1);
    v = vsetq_lane_s32(word(q + 2 * C + c), v, 2);
    return vsetq_lane_s32(word(q + 3 * C + c), v, 3);
  }
  static I byte(I w, int k) { return vshrq_n_s32(vshlq_s32(w, vdupq_n_s32(24 - 8 * k)), 24); }
  static I splat_i(int v) { return vdupq_n_s32(v); }
  static I max_i(I a, I b) { return vmaxq_s32(a, b); }
  static I sub_i(I a, I b) { return vsubq_s32(a, b); }
  static void store_i(int32_t* p, I v) { vst1q_s32(p, v); }
  static I load_i(const int32_t* p) { return vld1q_s32(p); }
  static F lookup(const float* t, I d) {
    F v = vld1q_dup_f32(t + vgetq_lane_s32(d, 0));
    v = vld1q_lane_f32(t + vgetq_lane_s32(d, 1), v, 1);
    v = vld1q_lane_f32(t + vgetq_lane_s32(d, 2), v, 2);
    return vld1q_lane_f32(t + vgetq_lane_s32(d, 3), v, 3);
  }
  static F zero_f() { return vdupq_n_f32(0.0f); }
  static F add_f(F a, F b) { return vaddq_f32(a, b); }
  static F recip(F s) { return vdivq_f32(vdupq_n_f32(1.0f), s); }
  static void store_f(float* p, F v) { vst1q_f32(p, v); }
};

}  // namespace

void softmax_i8__neon(const SoftmaxArgs& a) { softmax_pixels<SoftmaxN4, SoftmaxT4>(a); }

}  // namespace ef::nn
