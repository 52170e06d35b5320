// The one requantisation rule of the int8 runtime (docs/model_format.md, "Arithmetic"). Every
// layer and every SIMD variant computes exactly this, so all of them give identical bytes.
//
// An integer x (a convolution accumulator, a difference from a zero point, a pool sum) becomes an
// int8 output through one float32 multiplier m:
//     y = float(x) * m                            IEEE binary32 multiply, round to nearest even
//     y = min(max(y, float(lo - zp)), float(hi - zp))   clamp first, so the rounding cannot overflow
//     q = round_half_even(y) + zp                 y is within [-255, 255] here, so this is exact
// Why float32 and not a fixed-point multiply: on every SIMD ISA this is five instructions per vector
// (convert, multiply, max, min, convert) with no 64-bit lanes, it is what XNNPACK and TFLite's fp32
// requantisation do, and numpy restates it exactly on float32 arrays (np.float32 products are IEEE
// binary32; np.rint is round half to even). Conditions for bit-exactness, all held by this project:
// the default rounding mode (round to nearest even), no FMA contraction (-ffp-contract=off), and
// multipliers that are normal floats (the loader rejects others), so flush-to-zero cannot differ.
//
// All functions here are `static inline` (internal linkage): ISA-suffixed kernel files include this
// header, and see the rule in kernels/variants.h about inline functions in ISA files.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstdint>

namespace ef::nn {

// The multiplier of one output channel (conv), one input (add, concat) or one window size (avg pool).
struct Requant {
  float multiplier = 1.0f;
};

// Round half to even of a float within [-2^22, 2^22]: adding and subtracting 1.5 * 2^23 leaves the
// integer part, rounded by the FPU's default mode (nearest even), as cvtps2dq and NEON's FCVTNS do.
// Written out instead of std::nearbyint so that the scalar twin cannot be a library call that some
// libm implements differently; `volatile`-free because -ffp-contract=off and IEEE semantics
// (no -ffast-math anywhere in this project) keep the two operations.
static inline float round_half_even_small(float y) {
  const float magic = 12582912.0f;  // 1.5 * 2^23
  return (y + magic) - magic;
}

// The requantisation of an integer x: q = round_half_even(clamp(float(x) * m, lo - zp, hi - zp)) + zp.
// [lo, hi] is the output range with the fused activation folded in (a subset of [-128, 127]);
// zp the output zero point.
static inline int8_t requantize(int32_t x, float m, int32_t zp, int32_t lo, int32_t hi) {
  float y = static_cast<float>(x) * m;
  const float y_lo = static_cast<float>(lo - zp), y_hi = static_cast<float>(hi - zp);
  y = y < y_lo ? y_lo : (y > y_hi ? y_hi : y);
  return static_cast<int8_t>(static_cast<int32_t>(round_half_even_small(y)) + zp);
}
static inline int8_t requantize(int32_t x, Requant rq, int32_t zp, int32_t lo, int32_t hi) {
  return requantize(x, rq.multiplier, zp, lo, hi);
}

// The multiplier as the loader computes it from the tensors' float32 scales: the real ratio in
// double, evaluated left to right as written by the caller, rounded once to float32.
// Returns false when the result is not a normal float (zero, subnormal, infinite or NaN) or is at
// least 2^24 (a multiplier that large maps every accumulator step past the int8 range; it is a
// broken model, not a deliberate one).
static inline bool make_multiplier(double real, float* out) {
  const float m = static_cast<float>(real);
  if (!(m >= FLT_MIN) || !(m < 16777216.0f)) return false;  // also false for NaN
  *out = m;
  return true;
}

}  // namespace ef::nn
