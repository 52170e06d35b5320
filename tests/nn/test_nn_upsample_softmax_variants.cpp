// Every upsample_nearest_i8, upsample_bilinear_i8 and softmax_i8 variant the CPU can run
// (nn/eltwise_kernels.h) against upsample_nearest_i8_ref, upsample_bilinear_i8_ref and
// softmax_i8_ref: int8 outputs byte for byte, float outputs bit for bit.
// upsample: factors 1..16 (bilinear: 1..8 on the SIMD path, 9..16 on its reference fallback),
// channels 1..70 around the vector widths (4/8/16/32/64 +- 1), odd and 1-pixel widths and heights,
// 1x1 inputs, inputs at -128 / 127 / alternating extremes (the largest interpolation sums), and the
// shipped network's three bilinear x2 layers. softmax: classes 1..257 (around 4/8/16 and the
// 256-class limit; 257 runs the reference fallback), pixel counts around the 4/8/16-pixel groups,
// table scales from 1/64 to 64 (tables whose tail underflows to 0), equal logits, extreme logits,
// and the shipped 120x160x14 output. Tensors live in exact-size heap buffers, so any read or write
// past one is a heap overflow under ASan. Last, a head-shaped network through the executor at every
// ISA cap and with a thread pool: every int8 tensor and every probability bit as at Isa::scalar
// (test_nn_exec.cpp compares the int8 tensors of its tiny net only).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/thread_pool.h"
#include "kernels/kernel_test_util.h"
#include "nn/eltwise_kernels.h"
#include "nn/executor.h"
#include "nn/nn_test_util.h"

namespace ef::nn {
namespace {

using UpsampleVariant = kernels::KernelVariant<UpsampleI8Fn>;
using SoftmaxVariant = kernels::KernelVariant<SoftmaxI8Fn>;

const std::vector<const UpsampleVariant*>& nearest_variants() {
  static const std::vector<const UpsampleVariant*> v =
      ef::test::runnable_variants(kUpsampleNearestI8Variants, "upsample_nearest_i8");
  return v;
}
const std::vector<const UpsampleVariant*>& bilinear_variants() {
  static const std::vector<const UpsampleVariant*> v =
      ef::test::runnable_variants(kUpsampleBilinearI8Variants, "upsample_bilinear_i8");
  return v;
}
const std::vector<const SoftmaxVariant*>& softmax_variants() {
  static const std::vector<const SoftmaxVariant*> v = ef::test::runnable_variants(kSoftmaxI8Variants, "softmax_i8");
  return v;
}

using ef::test::Fill;
using ef::test::make_input;

// -------------------------------------------------------------------------------------------- upsample

void check_upsample(bool bilinear, int h, int w, int c, int f, std::mt19937& rng, Fill fill = Fill::kRandom) {
  const std::vector<int8_t> in = make_input(std::size_t(h) * w * c, fill, rng);
  const std::size_t out_n = std::size_t(h) * f * w * f * c;
  UpsampleArgs a;
  a.in = TensorI8{in.data(), h, w, c, 5};
  a.factor = f;
  std::vector<int8_t> want(out_n);
  a.out = MutTensorI8{want.data(), h * f, w * f, c, 5};
  (bilinear ? upsample_bilinear_i8_ref : upsample_nearest_i8_ref)(a);
  for (const UpsampleVariant* v : bilinear ? bilinear_variants() : nearest_variants()) {
    SCOPED_TRACE(std::string(v->name) + " in " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                 std::to_string(c) + " factor " + std::to_string(f) + " fill " + std::to_string(int(fill)));
    std::vector<int8_t> got(out_n, 0x55);
    a.out.data = got.data();
    v->fn(a);
    ASSERT_EQ(got, want);
  }
}

const int kUpsampleChannels[] = {1, 2, 3, 4, 5, 7, 8, 9, 13, 14, 15, 16, 17, 24, 31, 32, 33, 47, 48, 49, 63, 64, 65, 70};

TEST(UpsampleVariants, BilinearChannelsAndFactors) {
  std::mt19937 rng(60);
  std::uniform_int_distribution<int> hw(1, 7);
  for (int c : kUpsampleChannels)
    for (int f = 1; f <= 4; ++f) check_upsample(true, hw(rng), hw(rng), c, f, rng);
}

TEST(UpsampleVariants, BilinearAllFactors) {
  std::mt19937 rng(61);
  for (int f = 1; f <= 16; ++f)  // 9..16: the SIMD variants run the reference
    for (int c : {1, 3, 14, 16, 33})
      for (auto [h, w] : {std::pair{1, 1}, std::pair{1, 5}, std::pair{3, 1}, std::pair{3, 4}})
        check_upsample(true, h, w, c, f, rng);
}

TEST(UpsampleVariants, BilinearExtremes) {
  std::mt19937 rng(62);
  for (int f = 1; f <= 8; ++f)
    for (int c : {1, 8, 14, 31, 64, 65})
      for (Fill fill : {Fill::kMin, Fill::kMax, Fill::kAlternate}) check_upsample(true, 3, 5, c, f, rng, fill);
}

TEST(UpsampleVariants, BilinearOddSizes) {
  std::mt19937 rng(63);
  std::uniform_int_distribution<int> hw(1, 13), ch(1, 70), ff(1, 8);
  for (int it = 0; it < 150; ++it) check_upsample(true, hw(rng), hw(rng), ch(rng), ff(rng), rng);
}

TEST(UpsampleVariants, BilinearShippedShapes) {
  std::mt19937 rng(64);
  check_upsample(true, 15, 20, 64, 2, rng);
  check_upsample(true, 30, 40, 32, 2, rng);
  check_upsample(true, 60, 80, 14, 2, rng);
}

TEST(UpsampleVariants, Nearest) {
  std::mt19937 rng(65);
  std::uniform_int_distribution<int> hw(1, 7);
  for (int c : kUpsampleChannels)
    for (int f : {1, 2, 3, 4}) check_upsample(false, hw(rng), hw(rng), c, f, rng);
  for (int f = 1; f <= 16; ++f)
    for (int c : {1, 14, 64, 65}) {
      check_upsample(false, 1, 1, c, f, rng);
      check_upsample(false, 3, 2, c, f, rng);
    }
  check_upsample(false, 60, 80, 14, 2, rng);
}

// --------------------------------------------------------------------------------------------- softmax

// The loader's table for input scale s: table[d] = float(exp(-double(s) * d)).
std::vector<float> exp_table(float scale) {
  std::vector<float> t(256);
  for (int d = 0; d < 256; ++d) t[d] = static_cast<float>(std::exp(-double(scale) * d));
  return t;
}

void check_softmax(int h, int w, int c, float scale, std::mt19937& rng, Fill fill = Fill::kRandom) {
  const std::vector<int8_t> in = make_input(std::size_t(h) * w * c, fill, rng);
  const std::vector<float> table = exp_table(scale);
  const std::size_t n = in.size();
  SoftmaxArgs a;
  a.in = TensorI8{in.data(), h, w, c, 0};
  a.exp_table = table.data();
  std::vector<float> want(n);
  a.out = want.data();
  softmax_i8_ref(a);
  std::vector<uint32_t> want_bits(n);
  if (n) std::memcpy(want_bits.data(), want.data(), n * sizeof(float));
  for (const SoftmaxVariant* v : softmax_variants()) {
    SCOPED_TRACE(std::string(v->name) + " " + std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c) +
                 " scale " + std::to_string(scale) + " fill " + std::to_string(int(fill)));
    std::vector<float> got(n, -1.0f);
    a.out = got.data();
    v->fn(a);
    std::vector<uint32_t> got_bits(n);
    if (n) std::memcpy(got_bits.data(), got.data(), n * sizeof(float));
    ASSERT_EQ(got_bits, want_bits);  // bit for bit, not within a tolerance
  }
}

TEST(SoftmaxVariants, ClassesAndPixelCounts) {
  std::mt19937 rng(70);
  for (int c : {1, 2, 3, 4, 5, 7, 8, 9, 13, 14, 15, 16, 17, 31, 32, 33, 63, 64, 65})
    for (int pixels : {1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 47, 48, 49, 100})
      check_softmax(1, pixels, c, 0.1f, rng);
}

TEST(SoftmaxVariants, ShapesAndScales) {
  std::mt19937 rng(71);
  std::uniform_int_distribution<int> hw(1, 12), ch(1, 40);
  for (float scale : {1.0f / 64, 0.03f, 0.1f, 0.37f, 1.0f, 4.0f, 64.0f})  // 64: table[d >= 2] == 0
    for (int it = 0; it < 12; ++it) check_softmax(hw(rng), hw(rng), ch(rng), scale, rng);
}

TEST(SoftmaxVariants, EqualAndExtremeLogits) {
  std::mt19937 rng(72);
  for (int c : {1, 4, 14, 16, 17})
    for (Fill fill : {Fill::kMin, Fill::kMax, Fill::kAlternate}) {
      check_softmax(3, 11, c, 0.1f, rng, fill);
      check_softmax(3, 11, c, 20.0f, rng, fill);
    }
}

TEST(SoftmaxVariants, ClassLimit) {
  std::mt19937 rng(73);
  for (int c : {127, 255, 256, 257})  // 257 is past the format's limit: the reference fallback
    for (int pixels : {1, 16, 17, 35}) check_softmax(1, pixels, c, 0.05f, rng);
}

TEST(SoftmaxVariants, ShippedOutput) {
  std::mt19937 rng(74);
  check_softmax(120, 160, 14, 0.125f, rng);
  check_softmax(120, 160, 14, 0.0421f, rng);
}

// -------------------------------------------------------------------------------------------- executor

// The decoder end of a segmentation network at the shipped sizes, with every layer type whose
// variants are dispatched here:
//   t0 15x20x8 -pw-> t1 15x20x64 -bilinear x2-> t2 30x40x64
//   t0 -pw-> t3 15x20x64 -nearest x2-> t4 30x40x64            (another scale: requantised by the concat)
//   concat(t2, t4) -> t5 30x40x128 (t2's quantisation: copied) -avgpool 3x3 p1-> t6 -clamp-> t7
//   -pw-> t8 30x40x14 -bilinear x2-> t9 60x80x14 -softmax-> t10 (float)
ModelDesc head_net() {
  using test::layer;
  using test::tensor;
  std::mt19937 rng(80);
  ModelDesc d;
  d.name = "head";
  d.input_mean.assign(8, 0.0f);
  d.input_scale.assign(8, 1.0f / 32);
  for (int k = 0; k < 14; ++k) d.class_names.push_back("class" + std::to_string(k));
  d.tensors = {tensor(15, 20, 8, 0.03f, -3),    tensor(15, 20, 64, 0.05f, 4),   tensor(30, 40, 64, 0.05f, 4),
               tensor(15, 20, 64, 0.08f, -20),  tensor(30, 40, 64, 0.08f, -20), tensor(30, 40, 128, 0.05f, 4),
               tensor(30, 40, 128, 0.045f, 1),  tensor(30, 40, 128, 0.045f, 1), tensor(30, 40, 14, 0.11f, -7),
               tensor(60, 80, 14, 0.11f, -7),   test::float_tensor(60, 80, 14)};
  d.input_tensor = 0;
  d.output_tensor = 10;
  auto pw1 = layer(LayerType::kPointwiseConv2d, {0}, 1);
  test::fill_weights(pw1, 64, 8, rng);
  auto up1 = layer(LayerType::kUpsample, {1}, 2);
  up1.factor = 2;
  up1.mode = UpsampleMode::kBilinear;
  auto pw2 = layer(LayerType::kPointwiseConv2d, {0}, 3);
  test::fill_weights(pw2, 64, 8, rng);
  auto up2 = layer(LayerType::kUpsample, {3}, 4);
  up2.factor = 2;
  auto cat = layer(LayerType::kConcat, {2, 4}, 5);
  auto avg = layer(LayerType::kAvgPool, {5}, 6);
  avg.kernel_h = avg.kernel_w = 3;
  avg.pad_top = avg.pad_left = avg.pad_bottom = avg.pad_right = 1;
  auto clamp = layer(LayerType::kClamp, {6}, 7);
  clamp.act = Activation::kRelu;
  clamp.out_min = 1;  // ReLU at zero point 1
  auto pw3 = layer(LayerType::kPointwiseConv2d, {7}, 8);
  test::fill_weights(pw3, 14, 128, rng);
  auto up3 = layer(LayerType::kUpsample, {8}, 9);
  up3.factor = 2;
  up3.mode = UpsampleMode::kBilinear;
  auto sm = layer(LayerType::kSoftmax, {9}, 10);
  d.layers = {pw1, up1, pw2, up2, cat, avg, clamp, pw3, up3, sm};
  return d;
}

TEST(ExecutorVariants, HeadNetworkGivesTheReferenceBitsAtEveryCap) {
  auto bytes = serialize_model(head_net());
  ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
  auto model = load_model_memory(bytes->data(), bytes->size(), "head.efm");
  ASSERT_TRUE(model.ok()) << to_string(model.error());
  const Model& m = *model;
  std::vector<int8_t> input(15 * 20 * 8);
  std::mt19937 rng(81);
  for (auto& q : input) q = static_cast<int8_t>(rng());
  // Every int8 tensor (reuse off, so all stay readable) and the probabilities' bits.
  auto run = [&](kernels::Isa cap, ThreadPool* pool, std::vector<int8_t>* tensors, std::vector<uint32_t>* prob_bits,
                 std::string* names) {
    ExecutorOptions o;
    o.plan = PlanOptions{false, true, 64};  // in place on: clamp writes over the avg pool's output
    o.max_isa = cap;
    o.pool = pool;
    auto ex = Executor::create(m, o);
    ASSERT_TRUE(ex.ok()) << to_string(ex.error());
    std::vector<float> probs((*ex)->output_floats());
    ASSERT_TRUE((*ex)->run_quantized(input.data(), input.size(), probs.data(), probs.size()).ok());
    prob_bits->resize(probs.size());
    std::memcpy(prob_bits->data(), probs.data(), probs.size() * sizeof(float));
    tensors->clear();
    for (uint32_t t = 1; t + 1 < m.desc.tensors.size(); ++t) {
      const int8_t* p = (*ex)->tensor_data(t);
      ASSERT_NE(p, nullptr);
      tensors->insert(tensors->end(), p, p + m.desc.tensors[t].elements());
    }
    names->clear();
    for (std::size_t l = 0; l < m.desc.layers.size(); ++l) *names += std::string((*ex)->kernel_name(l)) + " ";
  };
  std::vector<int8_t> want, got;
  std::vector<uint32_t> want_bits, got_bits;
  std::string names;
  run(kernels::Isa::scalar, nullptr, &want, &want_bits, &names);
  // The logits (the last int8 tensor) spread over many values, so the softmax is not degenerate.
  std::vector<bool> seen(256, false);
  for (std::size_t i = want.size() - 60 * 80 * 14; i < want.size(); ++i) seen[want[i] + 128] = true;
  EXPECT_GE(std::count(seen.begin(), seen.end(), true), 32);
  ThreadPoolOptions po;
  po.threads = 2;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  for (kernels::Isa isa : {kernels::Isa::sse41, kernels::Isa::avx2, kernels::Isa::avx512vnni, kernels::Isa::neon,
                           kernels::Isa::neondot}) {
    if (!kernels::isa_available(isa)) continue;
    for (ThreadPool* p : {static_cast<ThreadPool*>(nullptr), pool->get()}) {
      run(isa, p, &got, &got_bits, &names);
      std::printf("[ variants ] head net, cap %s, %d thread(s): %s\n", kernels::isa_name(isa), p ? p->threads() : 1,
                  names.c_str());
      EXPECT_EQ(got, want) << "int8 tensors, cap " << kernels::isa_name(isa);
      EXPECT_EQ(got_bits, want_bits) << "probabilities, cap " << kernels::isa_name(isa);
    }
  }
}

}  // namespace
}  // namespace ef::nn
