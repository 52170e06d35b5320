// The one requantisation rule of the int8 runtime (docs/model_format.md, "Arithmetic"). Every
// layer and every SIMD variant calls these inline functions, so all of them give identical bytes.
//
// A real multiplier M > 0 is represented as an integer `mult` in [0, 2^31) and a right shift `shift`
// in [1, 62]: M ~= mult * 2^-shift. Applying it to an integer x is one exact int64 product followed
// by a rounding shift that rounds half towards +infinity:
//     y = (x * mult + 2^(shift-1)) >> shift          (arithmetic shift, i.e. floor division)
// That is what NEON's rounding shifts (SRSHR/SRSHL) and a plain `(p + r) >> s` on x86 compute, and
// numpy restates it exactly on int64 arrays.
//
// All functions here are `static inline` (internal linkage): ISA-suffixed kernel files will include
// this header, and see the rule in kernels/variants.h about inline functions in ISA files.
#pragma once

#include <cmath>
#include <cstdint>

namespace ef::nn {

// M ~= mult * 2^-shift. mult in [0, 2^31 - 1], shift in [1, 62].
struct Requant {
  int32_t mult = 0;
  int32_t shift = 1;
};

// Rounding right shift, half towards +infinity. |x| < 2^62 and 1 <= shift <= 62 keep x + 2^(shift-1)
// inside int64. Right shift of a negative int64 is arithmetic on every compiler we support (and
// defined so by C++20).
static inline int64_t rounding_rshift_i64(int64_t x, int shift) {
  return (x + (int64_t{1} << (shift - 1))) >> shift;
}

static inline int32_t clamp_i64(int64_t v, int32_t lo, int32_t hi) {
  return v < lo ? lo : (v > hi ? hi : static_cast<int32_t>(v));
}

// The requantisation of a convolution accumulator: out = clamp(zp + round(acc * M), lo, hi).
// acc: int32 accumulator (bias included); zp: output zero point; [lo, hi]: the output range with the
// fused activation folded in (a subset of [-128, 127]).
static inline int8_t requantize(int32_t acc, Requant rq, int32_t zp, int32_t lo, int32_t hi) {
  const int64_t scaled = rounding_rshift_i64(static_cast<int64_t>(acc) * rq.mult, rq.shift);
  return static_cast<int8_t>(clamp_i64(scaled + zp, lo, hi));
}

// Error codes of compute_multipliers.
enum class MultiplierFault { kOk, kNotPositive, kTooLarge };

// Computes fixed-point multipliers that share one shift for n real multipliers (n = 1 for a
// convolution channel, 2 for add, one per input... see the spec). Exactly, in IEEE double:
//   e      = exponent of max(M) as frexp gives it (max = f * 2^e, f in [0.5, 1))
//   shift  = min(31 - e, 62)            -- rejected (kTooLarge) when 31 - e < 2, i.e. max(M) >= 2^29
//   mult_i = floor(ldexp(M_i, shift) + 0.5)
//   if any mult_i == 2^31: shift -= 1 and recompute every mult_i (now each <= 2^30)
// ldexp is exact and ldexp(M_i, shift) <= 2^31 has its unit in the last place <= 2^-21, so the + 0.5
// is exact too: the result depends on nothing but the double values M_i.
// M_i must be finite and > 0 (kNotPositive otherwise). Tiny M_i give mult_i = 0 (output = zero point).
static inline MultiplierFault compute_multipliers(const double* reals, int n, int32_t* mults, int32_t* shift_out) {
  double max_m = 0;
  for (int i = 0; i < n; ++i) {
    if (!(reals[i] > 0) || !std::isfinite(reals[i])) return MultiplierFault::kNotPositive;
    if (reals[i] > max_m) max_m = reals[i];
  }
  int e = 0;
  (void)std::frexp(max_m, &e);
  int shift = 31 - e;
  if (shift < 2) return MultiplierFault::kTooLarge;
  if (shift > 62) shift = 62;
  for (int attempt = 0; attempt < 2; ++attempt) {
    bool overflow = false;
    for (int i = 0; i < n; ++i) {
      const double m = std::floor(std::ldexp(reals[i], shift) + 0.5);
      if (m >= 2147483648.0) overflow = true;
      mults[i] = overflow ? 0 : static_cast<int32_t>(m);
    }
    if (!overflow) break;
    --shift;  // a rounding carried to 2^31: one bit less of precision for every input
  }
  *shift_out = shift;
  return MultiplierFault::kOk;
}

}  // namespace ef::nn
