// A tiny RGB-D segmentation network for the segmenter and `edgefusion segment` tests: the shape of
// the shipped one (R, G, B, depth in; softmax over 14 classes out, at a lower resolution than the
// input) with three layers and random weights.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "core/classes.h"
#include "nn/model_format.h"
#include "nn/nn_test_util.h"

namespace ef::test {

// in_h x in_w x 4 -conv3x3 s2 p1 relu-> (in_h/2) x (in_w/2) x 8 -pointwise-> ... x classes -softmax->.
// in_h and in_w must be even. Class names are those of core/classes.h when classes == 14.
inline nn::ModelDesc tiny_seg_net(uint32_t in_h, uint32_t in_w, uint32_t classes = 14, uint32_t seed = 5,
                                  uint32_t in_channels = 4) {
  using nn::LayerType;
  std::mt19937 rng(seed);
  nn::ModelDesc d;
  d.name = "tiny-seg";
  // The shipped network's normalisation: RGB 0..255 -> -1..1, depth 0..6 m -> -1..1.
  d.input_mean.assign(in_channels, 127.5f);
  d.input_scale.assign(in_channels, 1.0f / 127.5f);
  if (in_channels == 4) {
    d.input_mean[3] = 3.0f;
    d.input_scale[3] = 1.0f / 3.0f;
  }
  for (uint32_t k = 0; k < classes; ++k)
    d.class_names.push_back(classes == kNumClassesWithUnknown ? std::string(class_name(int(k)))
                                                             : "class" + std::to_string(k));
  const uint32_t oh = in_h / 2, ow = in_w / 2;
  d.tensors = {tensor(in_h, in_w, in_channels, 1.0f / 127.0f, 0), tensor(oh, ow, 8, 0.05f, -128),
               tensor(oh, ow, classes, 0.1f, 0), float_tensor(oh, ow, classes)};
  d.input_tensor = 0;
  d.output_tensor = 3;
  auto conv = layer(LayerType::kConv2d, {0}, 1);
  conv.kernel_h = conv.kernel_w = 3;
  conv.stride_h = conv.stride_w = 2;
  conv.pad_top = conv.pad_left = 1;  // (in + 1 + 0 - 3) / 2 + 1 = in / 2 for even sizes
  conv.act = nn::Activation::kRelu;
  fill_weights(conv, 8, 3 * 3 * in_channels, rng);
  auto pw = layer(LayerType::kPointwiseConv2d, {1}, 2);
  fill_weights(pw, classes, 8, rng);
  auto sm = layer(LayerType::kSoftmax, {2}, 3);
  d.layers = {conv, pw, sm};
  return d;
}

// Serialises `desc` into `path` (the .efm writer validates it first). Empty string on success,
// else the error.
inline std::string write_model_file(const nn::ModelDesc& desc, const std::filesystem::path& path) {
  auto bytes = nn::serialize_model(desc);
  if (!bytes.ok()) return to_string(bytes.error());
  std::ofstream out(path, std::ios::binary);
  out.write(bytes->data(), static_cast<std::streamsize>(bytes->size()));
  return out ? "" : "cannot write " + path.string();
}

// tiny_seg_net(24, 32) (a 24x32 input, the 14 NYUv2 classes) written to dir/tiny-seg.efm: its path.
inline std::filesystem::path write_tiny_seg_model(const std::filesystem::path& dir) {
  const std::filesystem::path p = dir / "tiny-seg.efm";
  EXPECT_EQ(write_model_file(tiny_seg_net(24, 32), p), "");
  return p;
}

}  // namespace ef::test
