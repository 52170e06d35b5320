// crf_rows for AArch64 Advanced SIMD: one 16-float row is four q registers. FMUL then FADD in the
// reference's order (never FMLA, which rounds once: kernels build with -ffp-contract=off, and the
// intrinsics below are the unfused ones); the loops are kernels/crf_rows_simd.h.
#include <arm_neon.h>

#include "kernels/crf_rows_simd.h"

namespace ef::kernels {

namespace {
struct Q4 {
  using R = float32x4_t;
  static constexpr int kLanes = 4;
  static R zero() { return vdupq_n_f32(0.0f); }
  static R set1(float x) { return vdupq_n_f32(x); }
  static R load(const float* p) { return vld1q_f32(p); }
  static void store(float* p, R v) { vst1q_f32(p, v); }
  static R add(R a, R b) { return vaddq_f32(a, b); }
  static R mul(R a, R b) { return vmulq_f32(a, b); }
  static void prefetch(const float* p) { __builtin_prefetch(p); }
};
}  // namespace

const CrfRowsKernel crf_rows__neon = crf_rows_kernel<Q4>();

}  // namespace ef::kernels
