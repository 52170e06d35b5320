// Scalar reference of every layer of the int8 runtime: the specification that SIMD variants must
// match byte for byte (docs/model_format.md, "Arithmetic").
//
// Tensors are NHWC with N = 1, int8, tightly packed (pixel (x, y) channel c at (y * w + x) * c_count + c).
// Each op family has one argument struct and one function-pointer type; `<op>_ref` has exactly that
// type, so a later `<op>.inc` variant list and a dispatch table (kernels/variants.h) slot in without
// changing the executor. No function here allocates; none fails (the loader validated everything).
#pragma once

#include <cstdint>

#include "nn/requantize.h"
#include "nn/resize_taps.h"

namespace ef::nn {

// A borrowed int8 NHWC tensor (N = 1).
struct TensorI8 {
  const int8_t* data = nullptr;
  int h = 0, w = 0, c = 0;
  int32_t zero_point = 0;
};
struct MutTensorI8 {
  int8_t* data = nullptr;
  int h = 0, w = 0, c = 0;
  int32_t zero_point = 0;
};

// Convolution (k x k, depthwise, pointwise). Output pixel (ox, oy) reads input rows
// oy * stride_h - pad_top + ky * dilation_h (and likewise in x); positions outside the input count
// as the input zero point (they contribute nothing to the accumulator).
struct ConvArgs {
  TensorI8 in;
  MutTensorI8 out;
  int kernel_h = 1, kernel_w = 1, stride_h = 1, stride_w = 1, dilation_h = 1, dilation_w = 1;
  int pad_top = 0, pad_left = 0;
  const int8_t* weights = nullptr;  // file layout (model_format.h), what the _ref functions read
  const int32_t* bias = nullptr;    // [out.c]
  const Requant* requant = nullptr; // [out.c]
  int32_t out_min = -128, out_max = 127;
  // What a SIMD variant reads instead of `weights`: the bytes its pack() wrote at load
  // (nn/conv_kernels.h); nullptr for the references.
  const void* packed = nullptr;
  // Output rows to compute, [oy_begin, oy_end); oy_end < 0 means out.h. A thread pool splits a layer
  // by giving each task its own row range of the same arguments.
  int oy_begin = 0, oy_end = -1;
};
using ConvI8Fn = void (*)(const ConvArgs&);
void conv2d_i8_ref(const ConvArgs& a);     // weights [out.c][kh][kw][in.c]
void dwconv2d_i8_ref(const ConvArgs& a);   // weights [c][kh][kw], out.c == in.c
void pwconv2d_i8_ref(const ConvArgs& a);   // weights [out.c][in.c]; kernel 1, stride 1, no pad

// out = zp_out + round_half_even(clamp(float(a - zp_a) * m_a + float(b - zp_b) * m_b, lo - zp_out, hi - zp_out))
// in float32 (nn/requantize.h), m_x = s_x / s_out.
struct AddArgs {
  TensorI8 a, b;
  MutTensorI8 out;  // may alias a or b (element i is read before it is written)
  Requant rq_a, rq_b;
  int32_t out_min = -128, out_max = 127;
};
using AddI8Fn = void (*)(const AddArgs&);
void add_i8_ref(const AddArgs& a);

// Channel concatenation; each input requantised to the output's quantisation.
inline constexpr int kMaxConcatInputs = 16;
struct ConcatArgs {
  TensorI8 in[kMaxConcatInputs];
  Requant rq[kMaxConcatInputs];
  int count = 0;
  MutTensorI8 out;
};
using ConcatI8Fn = void (*)(const ConcatArgs&);
void concat_i8_ref(const ConcatArgs& a);

// out = clamp(in, lo, hi); in and out share their quantisation. out may alias in.
struct ClampArgs {
  TensorI8 in;
  MutTensorI8 out;
  int32_t out_min = -128, out_max = 127;
};
using ClampI8Fn = void (*)(const ClampArgs&);
void clamp_i8_ref(const ClampArgs& a);

// Pools. Windows cover only input positions (padding is skipped, never read as a value).
struct PoolArgs {
  TensorI8 in;
  MutTensorI8 out;
  int kernel_h = 1, kernel_w = 1, stride_h = 1, stride_w = 1, pad_top = 0, pad_left = 0;
  // avg: entry n - requant_count_base for a window of n input positions. The loader's table starts
  // at 1 (every count 1..kh*kw), except for a global pool (window = input, no padding), whose only
  // count is kh*kw: one entry, base kh*kw (docs/model_format.md 3.6).
  const Requant* requant_by_count = nullptr;
  int requant_count_base = 1;
};
using PoolI8Fn = void (*)(const PoolArgs&);
void maxpool_i8_ref(const PoolArgs& a);
void avgpool_i8_ref(const PoolArgs& a);

// Upsampling by an integer factor; in and out share their quantisation.
struct UpsampleArgs {
  TensorI8 in;
  MutTensorI8 out;
  int factor = 1;
};
using UpsampleI8Fn = void (*)(const UpsampleArgs&);
void upsample_nearest_i8_ref(const UpsampleArgs& a);
void upsample_bilinear_i8_ref(const UpsampleArgs& a);

// Bilinear resize to any output size (TensorFlow align_corners, docs/model_format.md 3.9); in and out
// share their quantisation and channels. Each output pixel blends four input pixels with the taps of
// nn/resize_taps.h: out = ((sum of weight products * (q + 128)) + 2^21) >> 22, minus 128.
struct ResizeArgs {
  TensorI8 in;
  MutTensorI8 out;
  // out.h row taps, then out.w column taps (resize_tap of each index), as the loader computed them.
  // The SIMD variants read these; the reference recomputes every tap from resize_tap().
  const ResizeTap* taps_y = nullptr;
  const ResizeTap* taps_x = nullptr;
};
using ResizeI8Fn = void (*)(const ResizeArgs&);
void resize_bilinear_i8_ref(const ResizeArgs& a);

// Per-pixel softmax over channels into float probabilities (HWC, classes innermost).
struct SoftmaxArgs {
  TensorI8 in;
  float* out = nullptr;            // in.h * in.w * in.c floats
  const float* exp_table = nullptr; // 256 entries: exp_table[d] = exp(-in_scale * d)
};
using SoftmaxI8Fn = void (*)(const SoftmaxArgs&);
void softmax_i8_ref(const SoftmaxArgs& a);

}  // namespace ef::nn
