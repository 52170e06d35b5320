// The .efm additions for imported networks (docs/model_format.md): the resize_bilinear layer, global
// average pools above kMaxKernel, and the class map of version 2 files. Round trips, the loader's
// refusals (each naming the file, the section, the layer and the fault), and version 1 models keeping
// their bytes.
#include <gtest/gtest.h>

#include <array>
#include <random>
#include <string>
#include <vector>

#include "nn/model_format.h"
#include "nn/nn_test_util.h"

namespace ef::nn {
namespace {

using test::expect_desc_rejected;
using test::expect_rejected;
using test::layer;
using test::tensor;

uint32_t u32_at(const std::string& b, std::size_t pos) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(uint8_t(b[pos + i])) << (8 * i);
  return v;
}

// t0 HxWx4 -pool or resize-> t1 -pw-> t2 ... -softmax-> float. `mid` is the layer under test, reading
// t0 and writing t1 (shape `t1`).
ModelDesc one_layer_net(uint32_t h, uint32_t w, const LayerDesc& mid, const TensorDesc& t1, uint32_t classes = 5) {
  std::mt19937 rng(5);
  ModelDesc d;
  d.name = "one";
  d.input_mean.assign(4, 0.0f);
  d.input_scale.assign(4, 1.0f / 64);
  for (uint32_t k = 0; k < classes; ++k) d.class_names.push_back("c" + std::to_string(k));
  d.tensors = {tensor(h, w, 4, 0.02f, -3), t1, tensor(t1.h, t1.w, classes, 0.1f, 2), test::float_tensor(t1.h, t1.w, classes)};
  d.input_tensor = 0;
  d.output_tensor = 3;
  auto pw = layer(LayerType::kPointwiseConv2d, {1}, 2);
  test::fill_weights(pw, classes, t1.c, rng);
  d.layers = {mid, pw, layer(LayerType::kSoftmax, {2}, 3)};
  return d;
}

ModelDesc resize_net(uint32_t h, uint32_t w, uint32_t oh, uint32_t ow) {
  return one_layer_net(h, w, layer(LayerType::kResizeBilinear, {0}, 1), tensor(oh, ow, 4, 0.02f, -3));
}

ModelDesc global_pool_net(uint32_t side) {
  auto gap = layer(LayerType::kAvgPool, {0}, 1);
  gap.kernel_h = gap.kernel_w = side;
  return one_layer_net(side, side, gap, tensor(1, 1, 4, 0.01f, 5));
}

// ------------------------------------------------------------------------------------ resize_bilinear

TEST(NnFormatResize, RoundTripAndTaps) {
  EXPECT_STREQ(layer_type_name(LayerType::kResizeBilinear), "resize_bilinear");
  EXPECT_EQ(kNumLayerTypes, 11);
  for (auto [h, w, oh, ow] : {std::array<uint32_t, 4>{1, 1, 33, 33}, {17, 25, 33, 49}, {33, 33, 17, 17}, {3, 3, 1, 1}}) {
    const ModelDesc d = resize_net(h, w, oh, ow);
    auto bytes = serialize_model(d);
    ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
    EXPECT_EQ(u32_at(*bytes, 4), kEfmVersion);  // a layer type, not a format change
    auto m = load_model_memory(bytes->data(), bytes->size(), "r.efm");
    ASSERT_TRUE(m.ok()) << to_string(m.error());
    EXPECT_EQ(m->desc.layers[0].type, LayerType::kResizeBilinear);
    const std::vector<ResizeTap>& taps = m->prepared[0].resize_taps;
    ASSERT_EQ(taps.size(), std::size_t(oh) + ow);
    for (uint32_t o = 0; o < oh; ++o) {
      const ResizeTap t = resize_tap(int32_t(o), int32_t(h), int32_t(oh));
      EXPECT_EQ(taps[o].i0, t.i0); EXPECT_EQ(taps[o].i1, t.i1); EXPECT_EQ(taps[o].w, t.w);
    }
    for (uint32_t o = 0; o < ow; ++o) EXPECT_EQ(taps[oh + o].w, resize_tap(int32_t(o), int32_t(w), int32_t(ow)).w);
    auto again = serialize_model(m->desc);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(*again, *bytes);
  }
  // The taps count in the model's bytes.
  auto a = load_model_memory(serialize_model(resize_net(17, 25, 33, 49))->data(),
                             serialize_model(resize_net(17, 25, 33, 49))->size(), "a.efm");
  auto b = load_model_memory(serialize_model(resize_net(17, 25, 66, 98))->data(),
                             serialize_model(resize_net(17, 25, 66, 98))->size(), "b.efm");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(b->bytes() - a->bytes(), (33u + 49u) * sizeof(ResizeTap));
}

TEST(NnFormatResize, Refusals) {
  ModelDesc d = resize_net(17, 25, 33, 49);
  d.tensors[1].scale = 0.03f;  // another scale
  expect_desc_rejected(d, {"LAYR", "layer 0 (resize_bilinear)", "quantisation must match"});
  d = resize_net(17, 25, 33, 49);
  d.tensors[1].zero_point = -2;  // another zero point
  expect_desc_rejected(d, {"LAYR", "layer 0 (resize_bilinear)", "quantisation must match"});
  d = resize_net(17, 25, 33, 49);
  d.tensors[1].c = 5;  // another channel count (the pointwise layer follows it)
  d.layers[1].weights.resize(5 * 5);
  expect_desc_rejected(d, {"LAYR", "layer 0 (resize_bilinear)", "changes channels 4 -> 5"});
  d = resize_net(17, 25, 33, 49);
  d.layers[0].inputs.push_back(0);
  expect_desc_rejected(d, {"LAYR", "layer 0 (resize_bilinear)", "2 inputs"});
  d = resize_net(17, 25, 33, 49);
  d.tensors[1].h = kMaxDim + 1;  // output sizes 1..kMaxDim (the tensor checks)
  expect_desc_rejected(d, {"TENS", "tensor 1", "outside 1..8192"});
  // A file of a build that knows no type 11 yet.
  d = resize_net(17, 25, 33, 49);
  std::string bytes = *serialize_model(d);
  const std::size_t layr = test::section_pos(bytes, "LAYR");
  bytes[layr + 12] = 11;  // tag, length, count, then the first record's type byte
  test::fix_crc(bytes);
  expect_rejected(bytes, {"LAYR", "layer 0", "unknown type 11"});
}

// --------------------------------------------------------------------------------- global avg pool

TEST(NnFormatGlobalPool, AcceptedUpTo256WithOneMultiplier) {
  for (uint32_t side : {5u, 31u, 33u, 65u, 256u}) {
    auto bytes = serialize_model(global_pool_net(side));
    ASSERT_TRUE(bytes.ok()) << side << ": " << to_string(bytes.error());
    auto m = load_model_memory(bytes->data(), bytes->size(), "g.efm");
    ASSERT_TRUE(m.ok()) << to_string(m.error());
    EXPECT_TRUE(is_global_pool(m->desc.layers[0], m->desc.tensors[0]));
    ASSERT_EQ(m->prepared[0].requant.size(), 1u) << side;  // the count side * side only
    EXPECT_EQ(m->prepared[0].requant[0].multiplier, float(double(0.02f) / double(0.01f) / double(side * side)));
  }
  // A pool that is not global keeps one multiplier per window count.
  ModelDesc d = global_pool_net(9);
  d.layers[0].kernel_h = d.layers[0].kernel_w = 3;
  d.layers[0].stride_h = d.layers[0].stride_w = 3;
  d.tensors[1].h = d.tensors[1].w = 3;
  d.tensors[2].h = d.tensors[2].w = d.tensors[3].h = d.tensors[3].w = 3;
  auto bytes = serialize_model(d);
  ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
  auto m = load_model_memory(bytes->data(), bytes->size(), "g.efm");
  ASSERT_TRUE(m.ok());
  EXPECT_FALSE(is_global_pool(m->desc.layers[0], m->desc.tensors[0]));
  EXPECT_EQ(m->prepared[0].requant.size(), 9u);
}

TEST(NnFormatGlobalPool, Refusals) {
  // 65x65 on a 66x66 input: a 2x2 output, not global.
  ModelDesc d = global_pool_net(65);
  d.tensors[0].h = d.tensors[0].w = 66;
  d.tensors[1].h = d.tensors[1].w = 2;
  d.tensors[2].h = d.tensors[2].w = d.tensors[3].h = d.tensors[3].w = 2;
  expect_desc_rejected(d, {"LAYR", "layer 0 (avg_pool)", "kernel 65x65 outside 1..31", "global average pool"});
  // Global in shape but with padding or a stride.
  d = global_pool_net(65);
  d.layers[0].pad_top = 1;
  expect_desc_rejected(d, {"LAYR", "layer 0 (avg_pool)", "kernel 65x65"});
  d = global_pool_net(65);
  d.layers[0].stride_h = 2;
  expect_desc_rejected(d, {"LAYR", "layer 0 (avg_pool)", "kernel 65x65"});
  // Above the limit.
  d = global_pool_net(257);
  expect_desc_rejected(d, {"LAYR", "layer 0 (avg_pool)", "outside 1..256"});
  // Max pools keep the 31 limit.
  d = global_pool_net(33);
  d.layers[0].type = LayerType::kMaxPool;
  d.tensors[1].scale = d.tensors[0].scale;
  d.tensors[1].zero_point = d.tensors[0].zero_point;
  expect_desc_rejected(d, {"LAYR", "layer 0 (max_pool)", "outside 1..31"});
  // The one multiplier is still checked.
  d = global_pool_net(65);
  d.tensors[1].scale = 1e-30f;
  expect_desc_rejected(d, {"LAYR", "layer 0 (avg_pool)", "window of 4225"});
}

// ---------------------------------------------------------------------------------------- class map

// The tiny net (5 outputs: wall, floor, chair, table, other) mapped into 14 classes.
ModelDesc mapped_net() {
  ModelDesc d = test::tiny_net();
  d.target_class_names = {"unknown", "bed",  "books", "ceiling", "chair",  "floor",  "furniture",
                          "objects", "picture", "sofa", "table",  "tv",     "wall",   "window"};
  d.class_map = {12, 5, 4, 10, 0};
  return d;
}

TEST(NnFormatClassMap, RoundTripAsVersion2) {
  const ModelDesc d = mapped_net();
  auto bytes = serialize_model(d);
  ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
  EXPECT_EQ(bytes->substr(0, 4), "EFM1");
  EXPECT_EQ(u32_at(*bytes, 4), kEfmVersionClassMap);
  const std::size_t cmap = test::section_pos(*bytes, "CMAP");
  ASSERT_NE(cmap, std::string::npos);
  // CMAP is the last section: tag, length, u32 targets, names, u32 entries, bytes.
  std::size_t body = 4 + 4 + 14;
  for (const auto& n : d.target_class_names) body += n.size();
  body += 5;
  EXPECT_EQ(u32_at(*bytes, cmap + 4), body);
  EXPECT_EQ(cmap + 8 + body, bytes->size());
  auto m = load_model_memory(bytes->data(), bytes->size(), "mapped.efm");
  ASSERT_TRUE(m.ok()) << to_string(m.error());
  EXPECT_EQ(m->desc.class_map, d.class_map);
  EXPECT_EQ(m->desc.target_class_names, d.target_class_names);
  EXPECT_EQ(m->desc.class_names, d.class_names);
  auto again = serialize_model(m->desc);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *bytes);
  // Without the map: version 1, the same bytes as the model always had, and no CMAP.
  const std::string plain = *serialize_model(test::tiny_net());
  EXPECT_EQ(u32_at(plain, 4), kEfmVersion);
  EXPECT_EQ(test::section_pos(plain, "CMAP"), std::string::npos);
  ModelDesc unmapped = m->desc;
  unmapped.class_map.clear();
  unmapped.target_class_names.clear();
  EXPECT_EQ(*serialize_model(unmapped), plain);
  EXPECT_EQ(m->bytes(), load_model_memory(plain.data(), plain.size(), "p.efm")->bytes() + 5 + body - 4 - 4 - 14 - 5);
  // Ids up to kMaxClasses - 1.
  ModelDesc big = test::tiny_net();
  big.target_class_names.assign(kMaxClasses, "t");
  big.class_map = {255, 0, 128, 1, 254};
  auto b = serialize_model(big);
  ASSERT_TRUE(b.ok()) << to_string(b.error());
  auto mb = load_model_memory(b->data(), b->size(), "big.efm");
  ASSERT_TRUE(mb.ok()) << to_string(mb.error());
  EXPECT_EQ(mb->desc.class_map, big.class_map);
}

TEST(NnFormatClassMap, Refusals) {
  ModelDesc d = mapped_net();
  d.class_map[3] = 14;  // 14 target classes: ids 0..13
  expect_desc_rejected(d, {"CMAP", "output channel 3 maps to class 14", "14 target classes"});
  d = mapped_net();
  d.class_map.push_back(1);
  expect_desc_rejected(d, {"CMAP", "6 map entries", "5 channels"});
  d = mapped_net();
  d.target_class_names.clear();
  expect_rejected(serialize_model_unchecked(d), {"CMAP", "target class"});
  EXPECT_FALSE(serialize_model(d).ok());
  d = mapped_net();
  d.class_map.clear();
  expect_rejected(serialize_model_unchecked(d), {"CMAP"});
  EXPECT_FALSE(serialize_model(d).ok());
  d = mapped_net();
  d.target_class_names[2] = "";
  expect_desc_rejected(d, {"CMAP", "target class 2", "empty"});
  d = mapped_net();
  d.target_class_names[2] = std::string(64, 'x');
  expect_desc_rejected(d, {"CMAP", "target class 2", "63"});
  d = mapped_net();
  d.target_class_names.assign(kMaxClasses + 1, "t");
  expect_desc_rejected(d, {"CMAP", "257 target classes"});
}

TEST(NnFormatClassMap, FramingRefusals) {
  const std::string v2 = *serialize_model(mapped_net());
  const std::string v1 = *serialize_model(test::tiny_net());
  const std::size_t cmap = test::section_pos(v2, "CMAP");
  // Version 2 without its CMAP section.
  std::string b = v2.substr(0, cmap);
  test::put_u32(b, 8, static_cast<uint32_t>(b.size() - kEfmHeaderBytes));
  test::fix_crc(b);
  expect_rejected(b, {"CMAP", "truncated"});
  // Version 1 with a CMAP section: bytes after the last section.
  b = v2;
  test::put_u32(b, 4, kEfmVersion);
  test::fix_crc(b);
  expect_rejected(b, {"payload", "after the last section"});
  // A version this build does not read.
  b = v2;
  test::put_u32(b, 4, 3);
  expect_rejected(b, {"header", "version 3"}, ErrorCode::kUnsupported);
  // Counts: no targets, more entries than the section holds, trailing bytes.
  b = v2;
  test::put_u32(b, cmap + 8, 0);
  test::fix_crc(b);
  expect_rejected(b, {"CMAP", "0 target classes"});
  const std::size_t entries = v2.size() - 5 - 4;
  b = v2;
  test::put_u32(b, entries, 6);
  test::fix_crc(b);
  expect_rejected(b, {"CMAP", "truncated"});
  b = v2;
  test::put_u32(b, entries, 4);
  test::fix_crc(b);
  expect_rejected(b, {"CMAP", "1 unexpected bytes"});
  b = v2;
  test::put_u32(b, entries, 0);
  test::fix_crc(b);
  expect_rejected(b, {"CMAP", "0 map entries"});
  // Cut anywhere inside CMAP with a consistent header: always refused.
  for (std::size_t n = cmap; n < v2.size(); ++n) {
    std::string cut = v2.substr(0, n);
    test::put_u32(cut, 8, static_cast<uint32_t>(n - kEfmHeaderBytes));
    test::fix_crc(cut);
    EXPECT_FALSE(load_model_memory(cut.data(), cut.size(), "cut.efm").ok()) << n;
  }
  EXPECT_TRUE(load_model_memory(v1.data(), v1.size(), "v1.efm").ok());
}

}  // namespace
}  // namespace ef::nn
