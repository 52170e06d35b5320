// The packed form of a conv_i8 layer (k x k and pointwise convolutions), shared by every SIMD
// variant: one pack routine parameterised by the layout each ISA wants, so the layouts are described
// once. Compiled for the baseline ISA; the variants call it from their ConvKernel rows.
//
// Blob (64-byte aligned sections, offsets in the header):
//   ConvPackHeader
//   int32 bias[cout_pad]     bias[o] - (in_zero_point + input_offset) * sum of weights of o, 0 beyond cout
//   float mult[cout_pad]     the requantisation multipliers, 0 beyond cout
//   int8  pad_pixel[cin_pad] in_zero_point: what an out-of-image tap reads (it contributes nothing)
//   weights, one panel of `lanes` output channels after another (panel p: channels p*lanes ..):
//     [tap][k / group][lane][group] elements of `element_bytes` (int8 or int16), 0 beyond cin / cout
// Why the bias correction: kernels multiply raw input bytes (plus `input_offset`, e.g. 128 to make
// them unsigned for VPDPBUSD) by the weights; sum (q + off) * w - (z + off) * sum w = sum (q - z) * w
// exactly in int32, and a padding tap reads z, so it adds (z + off) * w - ... = 0 as the spec says.
#pragma once

#include <cstddef>
#include <cstdint>

#include "nn/conv_kernels.h"

namespace ef::nn {

// How one ISA wants its weights.
struct ConvPackLayout {
  int lanes = 16;          // output channels per panel (one SIMD register of int32 accumulators)
  int group = 4;           // consecutive input channels per lane (4: VPDPBUSD / SDOT, 2: PMADDWD, 1: SMLAL)
  int element_bytes = 1;   // 1: int8 weights, 2: int16 weights
  int cin_multiple = 4;    // cin is padded to a multiple of this (the kernel's load step)
  int32_t input_offset = 0;  // added to every input byte by the kernel (128: the int8 -> uint8 flip)
};

struct alignas(64) ConvPackHeader {
  int32_t lanes, group, element_bytes;
  int32_t cin, cin_pad, cout, cout_pad, panels, taps;
  int32_t k_steps;           // cin_pad / group: steps per tap
  int32_t input_offset;
  uint32_t panel_bytes;      // bytes of one panel's weights
  uint32_t bias_offset, mult_offset, pad_offset, weights_offset;  // from the blob start
};

std::size_t conv_packed_bytes(const ConvPackLayout& layout, const ConvShape& shape);
void conv_pack(const ConvPackLayout& layout, const ConvShape& shape, const ConvParams& params, void* dst);

// Views of a packed blob.
inline const ConvPackHeader& conv_header(const void* blob) { return *static_cast<const ConvPackHeader*>(blob); }
inline const int32_t* conv_bias(const void* blob) {
  return reinterpret_cast<const int32_t*>(static_cast<const char*>(blob) + conv_header(blob).bias_offset);
}
inline const float* conv_mult(const void* blob) {
  return reinterpret_cast<const float*>(static_cast<const char*>(blob) + conv_header(blob).mult_offset);
}
inline const int8_t* conv_pad_pixel(const void* blob) {
  return reinterpret_cast<const int8_t*>(static_cast<const char*>(blob) + conv_header(blob).pad_offset);
}
inline const char* conv_panel(const void* blob, int panel) {
  const ConvPackHeader& h = conv_header(blob);
  return static_cast<const char*>(blob) + h.weights_offset + std::size_t(panel) * h.panel_bytes;
}

}  // namespace ef::nn
