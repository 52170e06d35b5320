// .efm v1 (version 2, the class map: test_nn_format_v2.cpp): round trip, and every kind of malformed file rejected with an error that names the file,
// the section, the layer or tensor and the fault.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "nn/model_format.h"
#include "nn/nn_test_util.h"
#include "test_support.h"

namespace ef::nn {
namespace {

using test::expect_desc_rejected;
using test::expect_rejected;
using test::tiny_net;

TEST(NnFormat, Crc32MatchesZlib) {
  // The standard check value of CRC-32/ISO-HDLC (zlib.crc32(b"123456789") == 0xCBF43926).
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926u);
  EXPECT_EQ(crc32("", 0), 0u);
}

TEST(NnFormat, RoundTrip) {
  const ModelDesc d = tiny_net();
  auto bytes = serialize_model(d);
  ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
  EXPECT_EQ(bytes->substr(0, 4), "EFM1");
  auto m = load_model_memory(bytes->data(), bytes->size(), "tiny.efm");
  ASSERT_TRUE(m.ok()) << to_string(m.error());
  const ModelDesc& r = m->desc;
  EXPECT_EQ(r.name, d.name);
  EXPECT_EQ(r.class_names, d.class_names);
  EXPECT_EQ(r.input_mean, d.input_mean);
  EXPECT_EQ(r.input_scale, d.input_scale);
  EXPECT_EQ(r.input_tensor, d.input_tensor);
  EXPECT_EQ(r.output_tensor, d.output_tensor);
  ASSERT_EQ(r.tensors.size(), d.tensors.size());
  for (size_t i = 0; i < d.tensors.size(); ++i) {
    EXPECT_EQ(r.tensors[i].dtype, d.tensors[i].dtype);
    EXPECT_EQ(r.tensors[i].h, d.tensors[i].h);
    EXPECT_EQ(r.tensors[i].w, d.tensors[i].w);
    EXPECT_EQ(r.tensors[i].c, d.tensors[i].c);
    EXPECT_EQ(r.tensors[i].scale, d.tensors[i].scale);
    EXPECT_EQ(r.tensors[i].zero_point, d.tensors[i].zero_point);
  }
  ASSERT_EQ(r.layers.size(), d.layers.size());
  for (size_t i = 0; i < d.layers.size(); ++i) {
    const LayerDesc &a = r.layers[i], &b = d.layers[i];
    EXPECT_EQ(a.type, b.type);
    EXPECT_EQ(a.act, b.act);
    EXPECT_EQ(a.inputs, b.inputs);
    EXPECT_EQ(a.output, b.output);
    EXPECT_EQ(a.kernel_h, b.kernel_h);
    EXPECT_EQ(a.dilation_w, b.dilation_w);
    EXPECT_EQ(a.pad_bottom, b.pad_bottom);
    EXPECT_EQ(a.out_min, b.out_min);
    EXPECT_EQ(a.out_max, b.out_max);
    EXPECT_EQ(a.factor, b.factor);
    EXPECT_EQ(a.mode, b.mode);
    EXPECT_EQ(a.weight_scales, b.weight_scales);
    EXPECT_EQ(a.bias, b.bias);
    EXPECT_EQ(a.weights, b.weights);
  }
  // Serialising the loaded description gives the same bytes.
  auto again = serialize_model(r);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *bytes);
}

TEST(NnFormat, LoadFromFileAndMissingFile) {
  auto bytes = serialize_model(tiny_net());
  ASSERT_TRUE(bytes.ok());
  const auto dir = test::scratch_dir("nn_format");
  const std::string path = (dir / "tiny.efm").string();
  { std::ofstream(path, std::ios::binary) << *bytes; }
  auto m = load_model(path);
  ASSERT_TRUE(m.ok()) << to_string(m.error());
  EXPECT_EQ(m->source, path);
  auto missing = load_model((dir / "none.efm").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

TEST(NnFormat, TruncatedAnywhere) {
  const std::string bytes = *serialize_model(tiny_net());
  for (size_t n = 0; n < bytes.size(); ++n) {
    auto m = load_model_memory(bytes.data(), n, "cut.efm");
    ASSERT_FALSE(m.ok()) << "accepted a file cut to " << n << " bytes";
    EXPECT_EQ(m.error().code, ErrorCode::kCorruptData);
  }
  // Cut and with the header's size and CRC made consistent: the section parser must catch it.
  for (size_t n = kEfmHeaderBytes; n < bytes.size(); n += 7) {
    std::string cut = bytes.substr(0, n);
    test::put_u32(cut, 8, static_cast<uint32_t>(n - kEfmHeaderBytes));
    test::fix_crc(cut);
    auto m = load_model_memory(cut.data(), cut.size(), "cut.efm");
    ASSERT_FALSE(m.ok()) << "accepted a consistent-header file cut to " << n << " bytes";
  }
  expect_rejected(bytes.substr(0, 10), {"header", "truncated"});
}

TEST(NnFormat, BadMagicVersionCrcAndTrailingData) {
  const std::string good = *serialize_model(tiny_net());
  std::string b = good;
  b[0] = 'X';
  expect_rejected(b, {"header", "magic"});
  b = good;
  test::put_u32(b, 4, 3);  // 1 and 2 (with a class map, test_nn_format_v2.cpp) are read
  expect_rejected(b, {"header", "version 3"}, ErrorCode::kUnsupported);
  b = good;
  b[b.size() - 3] ^= 0x40;  // a weight byte
  expect_rejected(b, {"header", "CRC"});
  b = good + "x";
  expect_rejected(b, {"header", "payload size"});
  b = good;
  test::put_u32(b, 8, 0xFFFFFFF0u);  // huge payload size
  expect_rejected(b, {"header", "payload size"});
}

TEST(NnFormat, SectionsOutOfOrder) {
  std::string b = *serialize_model(tiny_net());
  const size_t tens = test::section_pos(b, "TENS");
  b.replace(tens, 4, "LAYR");
  test::fix_crc(b);
  expect_rejected(b, {"TENS", "expected section"});
}

TEST(NnFormat, TensorIndexOutOfRange) {
  ModelDesc d = tiny_net();
  d.layers[3].inputs[1] = 99;
  expect_desc_rejected(d, {"LAYR", "layer 3 (add)", "input tensor 99 out of range"});
  d = tiny_net();
  d.layers[5].output = 1000;
  expect_desc_rejected(d, {"LAYR", "layer 5 (max_pool)", "output tensor 1000 out of range"});
  d = tiny_net();
  d.output_tensor = 13;
  expect_desc_rejected(d, {"META", "out of range"});
}

TEST(NnFormat, InconsistentShapes) {
  ModelDesc d = tiny_net();
  d.tensors[2].h = 5;  // depthwise stride 2 of 8 rows gives 4
  expect_desc_rejected(d, {"LAYR", "layer 1 (depthwise_conv2d)", "output shape"});
  d = tiny_net();
  d.tensors[9].c = 15;  // concat of 8 + 8 channels
  expect_desc_rejected(d, {"LAYR", "layer 8 (concat)", "sum to 16"});
  d = tiny_net();
  d.layers[0].weights.pop_back();
  expect_desc_rejected(d, {"LAYR", "layer 0 (conv2d)", "weights"});
  d = tiny_net();
  d.layers[10].kernel_h = 31;  // window larger than the padded input
  expect_desc_rejected(d, {"LAYR", "layer 10 (conv2d)", "window larger"});
  d = tiny_net();
  d.layers[5].pad_top = 2;  // pool padding >= window
  expect_desc_rejected(d, {"LAYR", "layer 5 (max_pool)", "padding"});
  d = tiny_net();
  d.tensors[7].c = 9;
  expect_desc_rejected(d, {"LAYR", "layer 6 (avg_pool)", "channels"});
}

TEST(NnFormat, BadScales) {
  for (float bad : {0.0f, -0.5f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    ModelDesc d = tiny_net();
    d.tensors[4].scale = bad;
    expect_desc_rejected(d, {"TENS", "tensor 4", "scale"});
    d = tiny_net();
    d.layers[2].weight_scales[5] = bad;
    expect_desc_rejected(d, {"LAYR", "layer 2 (pointwise_conv2d)", "channel 5"});
  }
  ModelDesc d = tiny_net();
  d.tensors[3].zero_point = 200;
  expect_desc_rejected(d, {"TENS", "tensor 3", "zero point"});
  d = tiny_net();
  d.input_scale[3] = 0.0f;
  expect_desc_rejected(d, {"META", "normalisation"});
  d = tiny_net();
  d.tensors[6].scale = 0.08f;  // max pool must not requantise
  expect_desc_rejected(d, {"LAYR", "layer 5 (max_pool)", "quantisation must match"});
  d = tiny_net();
  d.tensors[1].scale = 1e-15f;  // multiplier in*w/out >= 2^29
  expect_desc_rejected(d, {"LAYR", "layer 0 (conv2d)", "multiplier"});
}

TEST(NnFormat, ForwardReferenceAndDoubleProducer) {
  ModelDesc d = tiny_net();
  d.layers[1].inputs[0] = 3;  // produced by layer 2
  expect_desc_rejected(d, {"LAYR", "layer 1 (depthwise_conv2d)", "forward reference"});
  d = tiny_net();
  d.layers[2].output = 2;  // tensor 2 produced twice (and a self-cycle)
  expect_desc_rejected(d, {"LAYR", "layer 2", "already produced"});
  d = tiny_net();
  d.layers.pop_back();  // nobody produces the output
  expect_desc_rejected(d, {"LAYR", "no layer produces the output"});
}

TEST(NnFormat, ClassNames) {
  ModelDesc d = tiny_net();
  d.class_names.push_back("extra");
  expect_desc_rejected(d, {"META", "6 class names", "5 channels"});
  d = tiny_net();
  d.class_names.assign(300, "c");
  d.tensors[11].c = d.tensors[12].c = 300;
  expect_desc_rejected(d, {"META", "300 classes"});
  d = tiny_net();
  d.class_names[2] = std::string(64, 'a');
  expect_desc_rejected(d, {"META", "class 2"});
}

TEST(NnFormat, HugeSizesAndCounts) {
  ModelDesc d = tiny_net();
  d.tensors[10].h = 100000;
  expect_desc_rejected(d, {"TENS", "tensor 10", "dimension"});
  d = tiny_net();
  d.tensors[10].h = d.tensors[10].w = 8000;
  d.tensors[10].c = 8000;
  expect_desc_rejected(d, {"TENS", "tensor 10", "too large"});
  // A layer count far beyond the section: refused before anything is allocated for it.
  std::string b = *serialize_model(tiny_net());
  test::put_u32(b, test::section_pos(b, "LAYR") + 8, 4000);
  test::fix_crc(b);
  expect_rejected(b, {"LAYR", "truncated"});
  b = *serialize_model(tiny_net());
  test::put_u32(b, test::section_pos(b, "LAYR") + 8, 0xFFFFFFFFu);
  test::fix_crc(b);
  expect_rejected(b, {"LAYR", "4294967295 layers"});
  b = *serialize_model(tiny_net());
  test::put_u32(b, test::section_pos(b, "TENS") + 8, 0x7FFFFFFFu);
  test::fix_crc(b);
  expect_rejected(b, {"TENS", "tensors"});
  // A section length past the payload.
  b = *serialize_model(tiny_net());
  test::put_u32(b, test::section_pos(b, "WGHT") + 4, 0x10000000u);
  test::fix_crc(b);
  expect_rejected(b, {"WGHT", "runs past"});
}

TEST(NnFormat, WeightBlockOutOfRange) {
  std::string b = *serialize_model(tiny_net());
  // Layer 0's record: LAYR tag + length + count, then type/act/mode/nin (4), output (4), 1 input (4),
  // 10 u32 fields, out_min, out_max, factor, then the weight offset.
  const size_t rec = test::section_pos(b, "LAYR") + 12;
  const size_t woff = rec + 4 + 4 + 4 + 40 + 12;
  std::string c = b;
  test::put_u32(c, woff, 0x00FFFFF0u);
  test::fix_crc(c);
  expect_rejected(c, {"WGHT", "layer 0 (conv2d)", "outside the section"});
  c = b;
  test::put_u32(c, woff + 4, 12);
  test::fix_crc(c);
  expect_rejected(c, {"WGHT", "layer 0 (conv2d)", "too small"});
  c = b;
  test::put_u32(c, woff + 4, 100);  // scales and biases fit, the weights do not match the shapes
  test::fix_crc(c);
  expect_rejected(c, {"LAYR", "layer 0 (conv2d)", "needs 288 weights, has 36"});
  c = b;
  test::put_u32(c, woff, 2);
  test::fix_crc(c);
  expect_rejected(c, {"WGHT", "layer 0 (conv2d)", "multiple of 4"});
}

TEST(NnFormat, WeightAndParameterValues) {
  ModelDesc d = tiny_net();
  d.layers[0].weights[17] = -128;
  expect_desc_rejected(d, {"LAYR", "layer 0 (conv2d)", "-128"});
  d = tiny_net();
  d.layers[0].bias[1] = (1 << 30) + 1;
  expect_desc_rejected(d, {"LAYR", "layer 0 (conv2d)", "bias"});
  d = tiny_net();
  d.layers[4].out_min = 50; d.layers[4].out_max = 20;
  expect_desc_rejected(d, {"LAYR", "layer 4 (clamp)", "output range"});
  d = tiny_net();
  d.layers[7].factor = 0;
  expect_desc_rejected(d, {"LAYR", "layer 7 (upsample)", "factor"});
  d = tiny_net();
  d.layers[1].stride_h = 9;
  expect_desc_rejected(d, {"LAYR", "layer 1", "stride"});
  d = tiny_net();
  d.layers[3].inputs.push_back(2);
  expect_desc_rejected(d, {"LAYR", "layer 3 (add)", "inputs"});
  d = tiny_net();
  d.layers[5].bias = {1};  // the writer has no place for it, so only the checked writer sees it
  auto w = serialize_model(d);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().message.find("takes none"), std::string::npos) << w.error().message;
  d = tiny_net();
  d.tensors[5].dtype = DType::kFloat32; d.tensors[5].scale = 1; d.tensors[5].zero_point = 0;
  expect_desc_rejected(d, {"LAYR", "layer 4 (clamp)", "not int8"});
}

}  // namespace
}  // namespace ef::nn
