// The per-axis taps of resize_bilinear (docs/model_format.md 3.9): TensorFlow's align_corners rule
// in integers. Output index o of an axis whose input has n positions and whose output has m reads
// input positions i0 and i1 with weight w of i1 (and 2048 - w of i0), in units of 1/2048:
//   m == 1 or n == 1:  i0 = i1 = 0, w = 0
//   otherwise:         num = o * (n - 1), den = m - 1, i0 = num / den, r = num % den,
//                      i1 = min(i0 + 1, n - 1), w = (r * 2048 + den / 2) / den     (0 <= w <= 2048)
// The loader computes them once per layer (PreparedLayer::resize_taps); the reference recomputes
// them per output index from this same function.
//
// `static inline` (internal linkage): ISA-suffixed files include this header through layers_ref.h
// (the rule in kernels/variants.h).
#pragma once

#include <cstdint>

namespace ef::nn {

inline constexpr int kResizeWeightBits = 11;                  // weights in units of 1/2048
inline constexpr int32_t kResizeOne = 1 << kResizeWeightBits;  // 2048: the whole pixel
// The product of the two axes' weights is in units of 2^-22: out = (num + 2^21) >> 22.
inline constexpr int kResizeShift = 2 * kResizeWeightBits;

struct ResizeTap {
  int32_t i0 = 0, i1 = 0;  // input positions (rows or columns)
  int32_t w = 0;           // weight of i1 in 1/2048 (i0 has 2048 - w)
};

// The tap of output index o (0 <= o < m) on an axis of n input and m output positions (both
// 1..kMaxDim = 8192, so o * (n - 1) < 2^26 and r * 2048 < 2^24: no overflow).
static inline ResizeTap resize_tap(int32_t o, int32_t n, int32_t m) {
  ResizeTap t;
  if (m == 1 || n == 1) return t;
  const int32_t num = o * (n - 1), den = m - 1;
  t.i0 = num / den;
  const int32_t r = num % den;
  t.i1 = t.i0 + 1 < n ? t.i0 + 1 : n - 1;
  t.w = (r * kResizeOne + den / 2) / den;
  return t;
}

}  // namespace ef::nn
