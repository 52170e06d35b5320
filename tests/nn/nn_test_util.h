// Helpers for the nn tests: small hand-built models and byte patching of .efm files.
#pragma once

#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "nn/model_format.h"

namespace ef::test {

inline nn::TensorDesc tensor(uint32_t h, uint32_t w, uint32_t c, float scale, int32_t zp) {
  nn::TensorDesc t;
  t.h = h; t.w = w; t.c = c; t.scale = scale; t.zero_point = zp;
  return t;
}
inline nn::TensorDesc float_tensor(uint32_t h, uint32_t w, uint32_t c) {
  nn::TensorDesc t;
  t.dtype = nn::DType::kFloat32; t.h = h; t.w = w; t.c = c;
  return t;
}

// Random symmetric weights in [-127, 127], scales in [0.002, 0.02], biases in [-2000, 2000].
inline void fill_weights(nn::LayerDesc& l, uint32_t cout, uint32_t per_channel, std::mt19937& rng) {
  std::uniform_int_distribution<int> w(-127, 127), b(-2000, 2000);
  std::uniform_real_distribution<float> s(0.002f, 0.02f);
  l.weight_scales.resize(cout);
  l.bias.resize(cout);
  l.weights.resize(size_t(cout) * per_channel);
  for (auto& v : l.weight_scales) v = s(rng);
  for (auto& v : l.bias) v = b(rng);
  for (auto& v : l.weights) v = static_cast<int8_t>(w(rng));
}

inline nn::LayerDesc layer(nn::LayerType t, std::vector<uint32_t> in, uint32_t out) {
  nn::LayerDesc l;
  l.type = t; l.inputs = std::move(in); l.output = out;
  return l;
}

// A network that uses every layer type (12 layers), 8x8x4 input -> 8x8x5 probabilities:
//  t0 in 8x8x4 -conv3x3 p1 relu-> t1 8x8x8 -dw3x3 s2 p1-> t2 4x4x8 -pw-> t3 4x4x8
//  add(t2,t3) -> t4 -clamp relu6-> t5 -maxpool2 s2-> t6 2x2x8 -avgpool3 p1-> t7 2x2x8
//  -bilinear x2-> t8 4x4x8; concat(t8, t5) -> t9 4x4x16 -nearest x2-> t10 8x8x16
//  -conv3x3 dilation 2 p2-> t11 8x8x5 -softmax-> t12 (float)
inline nn::ModelDesc tiny_net(uint32_t seed = 1) {
  using nn::LayerType;
  std::mt19937 rng(seed);
  nn::ModelDesc d;
  d.name = "tiny";
  d.input_mean = {128.0f, 128.0f, 128.0f, 2.0f};
  d.input_scale = {1.0f / 64, 1.0f / 64, 1.0f / 64, 1.0f};
  d.class_names = {"wall", "floor", "chair", "table", "other"};
  d.tensors = {tensor(8, 8, 4, 0.02f, 0),    tensor(8, 8, 8, 0.05f, -128), tensor(4, 4, 8, 0.04f, 3),
               tensor(4, 4, 8, 0.06f, -5),   tensor(4, 4, 8, 0.07f, -10),  tensor(4, 4, 8, 0.07f, -10),
               tensor(2, 2, 8, 0.07f, -10),  tensor(2, 2, 8, 0.03f, 7),    tensor(4, 4, 8, 0.03f, 7),
               tensor(4, 4, 16, 0.08f, 0),   tensor(8, 8, 16, 0.08f, 0),   tensor(8, 8, 5, 0.1f, 2),
               float_tensor(8, 8, 5)};
  d.input_tensor = 0;
  d.output_tensor = 12;
  auto conv = layer(LayerType::kConv2d, {0}, 1);
  conv.kernel_h = conv.kernel_w = 3; conv.pad_top = conv.pad_left = conv.pad_bottom = conv.pad_right = 1;
  conv.act = nn::Activation::kRelu; conv.out_min = -128;  // zero point -128: ReLU is the full range
  fill_weights(conv, 8, 3 * 3 * 4, rng);
  auto dw = layer(LayerType::kDepthwiseConv2d, {1}, 2);
  dw.kernel_h = dw.kernel_w = 3; dw.stride_h = dw.stride_w = 2; dw.pad_top = dw.pad_left = dw.pad_bottom = dw.pad_right = 1;
  dw.pad_bottom = dw.pad_right = 0;
  fill_weights(dw, 8, 9, rng);
  auto pw = layer(LayerType::kPointwiseConv2d, {2}, 3);
  fill_weights(pw, 8, 8, rng);
  auto add = layer(LayerType::kAdd, {2, 3}, 4);
  auto clamp = layer(LayerType::kClamp, {4}, 5);
  clamp.act = nn::Activation::kRelu6; clamp.out_min = -10; clamp.out_max = -10 + 86;  // 6 / 0.07 = 85.7
  auto maxp = layer(LayerType::kMaxPool, {5}, 6);
  maxp.kernel_h = maxp.kernel_w = 2; maxp.stride_h = maxp.stride_w = 2;
  auto avgp = layer(LayerType::kAvgPool, {6}, 7);
  avgp.kernel_h = avgp.kernel_w = 3; avgp.pad_top = avgp.pad_left = avgp.pad_bottom = avgp.pad_right = 1;
  auto up1 = layer(LayerType::kUpsample, {7}, 8);
  up1.factor = 2; up1.mode = nn::UpsampleMode::kBilinear;
  auto cat = layer(LayerType::kConcat, {8, 5}, 9);
  auto up2 = layer(LayerType::kUpsample, {9}, 10);
  up2.factor = 2;
  auto head = layer(LayerType::kConv2d, {10}, 11);
  head.kernel_h = head.kernel_w = 3; head.dilation_h = head.dilation_w = 2;
  head.pad_top = head.pad_left = head.pad_bottom = head.pad_right = 2;
  fill_weights(head, 5, 3 * 3 * 16, rng);
  auto sm = layer(LayerType::kSoftmax, {11}, 12);
  d.layers = {conv, dw, pw, add, clamp, maxp, avgp, up1, cat, up2, head, sm};
  return d;
}

// Byte position of a section's tag ("META", "TENS", "LAYR", "WGHT") in a serialised file.
inline size_t section_pos(const std::string& bytes, const char* tag) {
  return bytes.find(std::string(tag, 4), nn::kEfmHeaderBytes);
}
inline void put_u32(std::string& bytes, size_t pos, uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes[pos + i] = static_cast<char>(v >> (8 * i));
}
// Recomputes the payload CRC in the header after a patch, so the fault under test is the one found.
inline void fix_crc(std::string& bytes) {
  put_u32(bytes, 12, nn::crc32(bytes.data() + nn::kEfmHeaderBytes, bytes.size() - nn::kEfmHeaderBytes));
}

// Int8 inputs for the layer variant tests: random, all -128, all 127, or alternating extremes.
enum class Fill { kRandom, kMin, kMax, kAlternate };

inline std::vector<int8_t> make_input(std::size_t n, Fill fill, std::mt19937& rng) {
  std::vector<int8_t> v(n);
  std::uniform_int_distribution<int> d(-128, 127);
  for (std::size_t i = 0; i < n; ++i) {
    switch (fill) {
      case Fill::kRandom: v[i] = static_cast<int8_t>(d(rng)); break;
      case Fill::kMin: v[i] = -128; break;
      case Fill::kMax: v[i] = 127; break;
      case Fill::kAlternate: v[i] = static_cast<int8_t>(((i * 7 + i / 5) & 1) ? 127 : -128); break;
    }
  }
  return v;
}

// Loads `bytes` as "bad.efm" and expects a failure with `code` whose message names the file and holds
// every one of `parts`.
inline void expect_rejected(const std::string& bytes, std::initializer_list<const char*> parts,
                            ErrorCode code = ErrorCode::kCorruptData) {
  auto m = nn::load_model_memory(bytes.data(), bytes.size(), "bad.efm");
  ASSERT_FALSE(m.ok()) << "accepted a malformed file";
  EXPECT_EQ(m.error().code, code) << m.error().message;
  EXPECT_NE(m.error().message.find("bad.efm"), std::string::npos) << m.error().message;
  for (const char* p : parts)
    EXPECT_NE(m.error().message.find(p), std::string::npos) << "missing '" << p << "' in: " << m.error().message;
}

// Writes `d` unchecked and expects the loader to reject it, and the checked writer to refuse it.
inline void expect_desc_rejected(const nn::ModelDesc& d, std::initializer_list<const char*> parts) {
  expect_rejected(nn::serialize_model_unchecked(d), parts);
  EXPECT_FALSE(nn::serialize_model(d).ok()) << "the checked writer accepted it";
}

}  // namespace ef::test
