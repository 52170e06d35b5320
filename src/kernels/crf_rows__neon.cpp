// crf_rows for AArch64 Advanced SIMD: one 16-float row is four q registers. FMUL then FADD in the
// reference's order (never FMLA, which rounds once: kernels build with -ffp-contract=off, and the
// intrinsics below are the unfused ones).
#include <arm_neon.h>

#include "kernels/crf_rows_variants.h"

namespace ef::kernels {

namespace {
constexpr int V = kCrfRowFloats;
constexpr int K = kCrfSimplex;
// Prefetch distance (points): rows are scattered over a lattice larger than L2, but points come in
// spatial order, so the rows a few points ahead are the ones to fetch.
constexpr std::size_t kPrefetch = 4;

void prefetch_rows(const float* rows, const uint32_t* v) {
  for (int k = 0; k < K; ++k) __builtin_prefetch(rows + std::size_t(v[k]) * V);
}

void slice(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, float* out) {
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kPrefetch < points) prefetch_rows(rows, vertices + (p + kPrefetch) * K);
    const uint32_t* v = vertices + p * K;
    const uint16_t* w = weights + p * K;
    float32x4_t a0 = vdupq_n_f32(0.0f), a1 = a0, a2 = a0, a3 = a0;
    for (int k = 0; k < K; ++k) {
      const float* r = rows + std::size_t(v[k]) * V;
      const float32x4_t wk = vdupq_n_f32(float(w[k]));
      a0 = vaddq_f32(a0, vmulq_f32(wk, vld1q_f32(r)));
      a1 = vaddq_f32(a1, vmulq_f32(wk, vld1q_f32(r + 4)));
      a2 = vaddq_f32(a2, vmulq_f32(wk, vld1q_f32(r + 8)));
      a3 = vaddq_f32(a3, vmulq_f32(wk, vld1q_f32(r + 12)));
    }
    vst1q_f32(out + p * V, a0);
    vst1q_f32(out + p * V + 4, a1);
    vst1q_f32(out + p * V + 8, a2);
    vst1q_f32(out + p * V + 12, a3);
  }
}

void splat(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, const float* in) {
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kPrefetch < points) prefetch_rows(rows, vertices + (p + kPrefetch) * K);
    const uint32_t* v = vertices + p * K;
    const uint16_t* w = weights + p * K;
    const float32x4_t x0 = vld1q_f32(in + p * V), x1 = vld1q_f32(in + p * V + 4);
    const float32x4_t x2 = vld1q_f32(in + p * V + 8), x3 = vld1q_f32(in + p * V + 12);
    for (int k = 0; k < K; ++k) {
      float* r = rows + std::size_t(v[k]) * V;
      const float32x4_t wk = vdupq_n_f32(float(w[k]));
      vst1q_f32(r, vaddq_f32(vld1q_f32(r), vmulq_f32(wk, x0)));
      vst1q_f32(r + 4, vaddq_f32(vld1q_f32(r + 4), vmulq_f32(wk, x1)));
      vst1q_f32(r + 8, vaddq_f32(vld1q_f32(r + 8), vmulq_f32(wk, x2)));
      vst1q_f32(r + 12, vaddq_f32(vld1q_f32(r + 12), vmulq_f32(wk, x3)));
    }
  }
}

void blur(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end) {
  const float32x4_t half = vdupq_n_f32(0.5f), quarter = vdupq_n_f32(0.25f);
  for (std::size_t v = begin; v < end; ++v) {
    const float* m = in + std::size_t(neighbours[2 * v]) * V;
    const float* p = in + std::size_t(neighbours[2 * v + 1]) * V;
    const float* c = in + v * V;
    for (int h = 0; h < V; h += 4)
      vst1q_f32(out + v * V + h,
                vaddq_f32(vmulq_f32(half, vld1q_f32(c + h)), vmulq_f32(quarter, vaddq_f32(vld1q_f32(m + h), vld1q_f32(p + h)))));
  }
}
}  // namespace

const CrfRowsKernel crf_rows__neon = {&slice, &splat, &blur};

}  // namespace ef::kernels
