// The loop nest of every SIMD softmax_i8 variant, written once (docs/model_format.md 3.8).
// Vectorised across pixels: a vector holds one class of N consecutive pixels (N = 4, 8 or 16), so
// each lane runs the reference's per-pixel arithmetic in the reference's order:
//   qmax  = max over classes                        (int32 lanes)
//   sum   = ((0 + e_0) + e_1) + ... + e_{C-1}       float32 adds in class order, e_c = table[qmax - q_c]
//   inv   = 1.0f / sum                              an IEEE division (never a reciprocal estimate)
//   p_c   = e_c * inv                               one float32 multiply
// so the floats are bit-identical to softmax_i8_ref. Per group of N pixels:
//   pass 1 reads 4 classes of the N pixels at once: one 32-bit word per pixel (a gather or scalar
//          loads at q + l * C + c), whose bytes are classes c .. c + 3; each class is one byte
//          sign-extended out of the words. The words of the last classes start at C - 4 (overlapping
//          the previous ones) so nothing is read past a pixel; with C < 4 they run past the pixel,
//          and a group whose words would run past the tensor goes to the reference. The classes go
//          into a class-major scratch and into the max.
//   pass 2 looks the exponentials up (a gather or scalar loads), stores them class-major and sums;
//   pass 3 multiplies by inv and transposes [class][pixel] back to the pixel-major output in 4 x 4
//          blocks (classes beyond a multiple of 4 one float at a time).
// Pixels after the last whole group go through softmax_i8_ref, as do layers with more classes than
// the format allows: the two class-major scratch arrays on the stack are sized for 256 classes,
// 2 * 256 * N * 4 bytes (32 KiB for N = 16; nothing is allocated).
//
// V (one ISA's pixel vectors) provides:
//   kPixels (N), I, F, Offs;  Offs offsets(int C)
//   I load_words(const int8_t* q, const Offs&, int c)   lane l: the 4 bytes at q + l * C + c
//   I byte(I words, int k)                              byte k of each lane, sign-extended
//   I splat_i(int); I max_i(I, I); I sub_i(I, I); void store_i(int32_t*, I); I load_i(const int32_t*)
//   F lookup(const float* table, I d); F zero_f(); F add_f(F, F); F recip(F); void store_f(float*, F)
// T4 (4-float vectors for the transposition): R, load(const float*), mul(R, R), store(float*, R),
//   transpose(R&, R&, R&, R&).
#pragma once

#include <cstddef>
#include <cstdint>

#include "nn/layers_ref.h"

#if defined(__x86_64__)
#include <immintrin.h>
#elif defined(__aarch64__)
#include <arm_neon.h>
#endif

namespace ef::nn {
namespace {

#if defined(__x86_64__)
// 4-float vectors for the output transposition (SSE; VEX-encoded in the AVX files).
struct SoftmaxT4 {
  using R = __m128;
  static R load(const float* p) { return _mm_loadu_ps(p); }
  static R mul(R a, R b) { return _mm_mul_ps(a, b); }
  static void store(float* p, R v) { _mm_storeu_ps(p, v); }
  static void transpose(R& r0, R& r1, R& r2, R& r3) { _MM_TRANSPOSE4_PS(r0, r1, r2, r3); }
};
#elif defined(__aarch64__)
struct SoftmaxT4 {
  using R = float32x4_t;
  static R load(const float* p) { return vld1q_f32(p); }
  static R mul(R a, R b) { return vmulq_f32(a, b); }
  static void store(float* p, R v) { vst1q_f32(p, v); }
  static void transpose(R& r0, R& r1, R& r2, R& r3) {
    // TRN1/TRN2 on 32-bit lanes, then on 64-bit halves.
    const float32x4_t t0 = vtrn1q_f32(r0, r1), t1 = vtrn2q_f32(r0, r1);
    const float32x4_t t2 = vtrn1q_f32(r2, r3), t3 = vtrn2q_f32(r2, r3);
    r0 = vreinterpretq_f32_f64(vtrn1q_f64(vreinterpretq_f64_f32(t0), vreinterpretq_f64_f32(t2)));
    r1 = vreinterpretq_f32_f64(vtrn1q_f64(vreinterpretq_f64_f32(t1), vreinterpretq_f64_f32(t3)));
    r2 = vreinterpretq_f32_f64(vtrn2q_f64(vreinterpretq_f64_f32(t0), vreinterpretq_f64_f32(t2)));
    r3 = vreinterpretq_f32_f64(vtrn2q_f64(vreinterpretq_f64_f32(t1), vreinterpretq_f64_f32(t3)));
  }
};
#endif

inline constexpr int kSoftmaxMaxClasses = 256;  // the format's class limit (META num_classes)

// out[l * C + c] = e[c * N + l] * inv[l] for l < N, c < C.
template <class T4>
inline void softmax_write_probs(const float* e, const float* inv, int N, int C, float* out) {
  int c = 0;
  for (; c + 4 <= C; c += 4)
    for (int l = 0; l < N; l += 4) {
      const typename T4::R s = T4::load(inv + l);
      typename T4::R r0 = T4::mul(T4::load(e + (c + 0) * N + l), s);
      typename T4::R r1 = T4::mul(T4::load(e + (c + 1) * N + l), s);
      typename T4::R r2 = T4::mul(T4::load(e + (c + 2) * N + l), s);
      typename T4::R r3 = T4::mul(T4::load(e + (c + 3) * N + l), s);
      T4::transpose(r0, r1, r2, r3);  // r_j: pixel l + j, classes c .. c + 3
      T4::store(out + std::ptrdiff_t(l + 0) * C + c, r0);
      T4::store(out + std::ptrdiff_t(l + 1) * C + c, r1);
      T4::store(out + std::ptrdiff_t(l + 2) * C + c, r2);
      T4::store(out + std::ptrdiff_t(l + 3) * C + c, r3);
    }
  for (; c < C; ++c)
    for (int l = 0; l < N; ++l) out[std::ptrdiff_t(l) * C + c] = e[c * N + l] * inv[l];
}

template <class V, class T4>
void softmax_pixels(const SoftmaxArgs& a) {
  constexpr int N = V::kPixels;
  static_assert(N % 4 == 0, "pixel groups are transposed in 4 x 4 blocks");
  const int C = a.in.c;
  const std::ptrdiff_t pixels = std::ptrdiff_t(a.in.h) * a.in.w;
  std::ptrdiff_t p0 = 0;
  if (C <= kSoftmaxMaxClasses) {
    alignas(64) int32_t qs[kSoftmaxMaxClasses * N];  // class-major: qs[c * N + l]
    alignas(64) float es[kSoftmaxMaxClasses * N];
    alignas(64) float inv[N];
    const typename V::Offs offs = V::offsets(C);
    const float* table = a.exp_table;
    // A group reads bytes up to (its last pixel) * C + max(C, 4).
    const std::ptrdiff_t bytes = pixels * C, reach = C < 4 ? 4 : C;
    for (; p0 + N <= pixels && (p0 + N - 1) * C + reach <= bytes; p0 += N) {
      const int8_t* q = a.in.data + p0 * C;
      typename V::I qmax = V::splat_i(-128);
      for (int c = 0; c < C; c += 4) {
        const int c0 = C < 4 ? 0 : (c + 4 <= C ? c : C - 4);  // first class in the words
        const typename V::I words = V::load_words(q, offs, c0);
        for (int k = c; k < c + 4 && k < C; ++k) {
          const typename V::I v = V::byte(words, k - c0);
          V::store_i(qs + k * N, v);
          qmax = V::max_i(qmax, v);
        }
      }
      typename V::F sum = V::zero_f();
      for (int c = 0; c < C; ++c) {
        const typename V::F e = V::lookup(table, V::sub_i(qmax, V::load_i(qs + c * N)));
        V::store_f(es + c * N, e);
        sum = V::add_f(sum, e);
      }
      V::store_f(inv, V::recip(sum));
      softmax_write_probs<T4>(es, inv, N, C, a.out + p0 * C);
    }
  }
  if (p0 < pixels) {
    SoftmaxArgs rest = a;  // a 1 x (pixels - p0) view of the remaining pixels
    rest.in.data += p0 * C;
    rest.in.h = 1;
    rest.in.w = static_cast<int>(pixels - p0);
    rest.out += p0 * C;
    softmax_i8_ref(rest);
  }
}

}  // namespace
}  // namespace ef::nn
