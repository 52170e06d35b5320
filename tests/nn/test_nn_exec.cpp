// Planner and executor: arena reuse is real and harmless, a hand-computed network end to end.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "nn/executor.h"
#include "nn/nn_test_util.h"
#include "nn/planner.h"

namespace ef::nn {
namespace {

Model load_tiny(uint32_t seed = 1) {
  auto bytes = serialize_model(test::tiny_net(seed));
  EXPECT_TRUE(bytes.ok());
  auto m = load_model_memory(bytes->data(), bytes->size(), "tiny.efm");
  EXPECT_TRUE(m.ok()) << to_string(m.error());
  return std::move(m).value();
}

std::vector<float> random_input(const Executor& ex, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> colour(0.0f, 255.0f), depth(0.0f, 5.0f);
  std::vector<float> in(ex.input_floats());
  for (size_t i = 0; i < in.size(); ++i) in[i] = (i % 4 == 3) ? depth(rng) : colour(rng);
  return in;
}

TEST(NnPlanner, ReuseBelowSumAndNoLiveOverlap) {
  const Model m = load_tiny();
  auto plan = plan_memory(m);
  ASSERT_TRUE(plan.ok());
  EXPECT_LT(plan->total_bytes, plan->sum_bytes);
  EXPECT_GE(plan->in_place_count, 2);  // add over a dying input, clamp over the add's output
  const auto& d = m.desc;
  for (size_t a = 0; a < d.tensors.size(); ++a)
    for (size_t b = a + 1; b < d.tensors.size(); ++b) {
      if (plan->offset[a] == MemoryPlan::kNotInArena || plan->offset[b] == MemoryPlan::kNotInArena) continue;
      const bool live_together = plan->first_use[a] <= plan->last_use[b] && plan->first_use[b] <= plan->last_use[a];
      const bool overlap = plan->offset[a] < plan->offset[b] + plan->bytes[b] && plan->offset[b] < plan->offset[a] + plan->bytes[a];
      if (!live_together || !overlap) continue;
      // Only an in-place pair may share bytes while both live: the consumer is an add or clamp that
      // writes one over the other, and the first dies at that layer.
      const size_t early = plan->first_use[a] < plan->first_use[b] ? a : b, late = early == a ? b : a;
      const int li = plan->first_use[late];
      ASSERT_GE(li, 0);
      const auto t = d.layers[li].type;
      EXPECT_TRUE((t == LayerType::kAdd || t == LayerType::kClamp) && plan->last_use[early] == li)
          << "tensors " << a << " and " << b << " overlap while live";
    }
  for (size_t t = 0; t < d.tensors.size(); ++t)
    if (plan->offset[t] != MemoryPlan::kNotInArena) {
      EXPECT_LE(plan->offset[t] + plan->bytes[t], plan->total_bytes);
    }
  EXPECT_EQ(plan->offset[d.output_tensor], MemoryPlan::kNotInArena);  // float output: the caller's buffer

  auto flat = plan_memory(m, PlanOptions{false, false, 64});
  ASSERT_TRUE(flat.ok());
  EXPECT_EQ(flat->total_bytes, flat->sum_bytes);
  EXPECT_EQ(flat->in_place_count, 0);
  std::printf("[ plan ] tiny net: %zu bytes with reuse, %zu without\n", plan->total_bytes, flat->total_bytes);
}

TEST(NnExecutor, ReuseGivesIdenticalOutput) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const Model m = load_tiny(seed);
    auto reuse = Executor::create(m);
    auto flat = Executor::create(m, PlanOptions{false, false, 64});
    ASSERT_TRUE(reuse.ok() && flat.ok());
    EXPECT_LT((*reuse)->arena_bytes(), (*flat)->arena_bytes());
    const auto in = random_input(**reuse, seed);
    std::vector<float> p1((*reuse)->output_floats()), p2(p1.size());
    ASSERT_TRUE((*reuse)->run(in.data(), in.size(), p1.data(), p1.size()).ok());
    ASSERT_TRUE((*flat)->run(in.data(), in.size(), p2.data(), p2.size()).ok());
    EXPECT_EQ(p1, p2);  // bit-identical
    // Probabilities: each pixel sums to 1; not all the same class (the network is not degenerate).
    for (size_t p = 0; p < p1.size() / 5; ++p) {
      float s = 0;
      for (int c = 0; c < 5; ++c) s += p1[p * 5 + c];
      EXPECT_NEAR(s, 1.0f, 1e-5f);
    }
    // A second run on the same input gives the same bytes (no state carried between runs).
    std::vector<float> p3(p1.size());
    ASSERT_TRUE((*reuse)->run(in.data(), in.size(), p3.data(), p3.size()).ok());
    EXPECT_EQ(p1, p3);
  }
}

TEST(NnExecutor, RejectsWrongBufferSizes) {
  const Model m = load_tiny();
  auto ex = Executor::create(m);
  ASSERT_TRUE(ex.ok());
  std::vector<float> in((*ex)->input_floats()), out((*ex)->output_floats());
  EXPECT_EQ((*ex)->run(in.data(), in.size() - 1, out.data(), out.size()).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ((*ex)->run(in.data(), in.size(), out.data(), out.size() + 1).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ((*ex)->run(nullptr, in.size(), out.data(), out.size()).error().code, ErrorCode::kInvalidArgument);
}

// 1x2 image, 4 channels -> pointwise conv (3 classes) -> softmax, every value computed by hand.
TEST(NnExecutor, HandComputedNetwork) {
  ModelDesc d;
  d.name = "hand";
  d.input_mean = {0, 0, 0, 0};
  d.input_scale = {1, 1, 1, 1};
  d.class_names = {"a", "b", "c"};
  d.tensors = {test::tensor(1, 2, 4, 0.5f, 0), test::tensor(1, 2, 3, 0.125f, 0), test::float_tensor(1, 2, 3)};
  d.input_tensor = 0;
  d.output_tensor = 2;
  auto pw = test::layer(LayerType::kPointwiseConv2d, {0}, 1);
  pw.weight_scales = {0.25f, 0.25f, 0.25f};  // multiplier 0.5 * 0.25 / 0.125 = 1 exactly
  pw.bias = {0, 0, 0};
  pw.weights = {1, 0, 0, 0, /**/ 0, 1, 0, 0, /**/ 0, 0, 1, 1};
  d.layers = {pw, test::layer(LayerType::kSoftmax, {1}, 2)};
  auto bytes = serialize_model(d);
  ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
  auto m = load_model_memory(bytes->data(), bytes->size(), "hand.efm");
  ASSERT_TRUE(m.ok()) << to_string(m.error());
  EXPECT_EQ(m->prepared[0].requant[0].multiplier, 1.0f);
  auto ex = Executor::create(*m);
  ASSERT_TRUE(ex.ok());
  // Quantised input (scale 0.5): 2 -> 4, 4 -> 8, -2 -> -4, 1 -> 2; 1.25 -> 2.5 -> 3 and -1.25 -> -3
  // (half away from zero); 100 -> 200 -> saturates at 127; NaN -> the zero point.
  const float in[8] = {2, 4, -2, 1, 1.25f, -1.25f, 100, std::nanf("")};
  float probs[6];
  ASSERT_TRUE((*ex)->run(in, 8, probs, 6).ok());
  const int8_t* q = (*ex)->tensor_data(0);
  ASSERT_NE(q, nullptr);
  const int8_t want_q[8] = {4, 8, -4, 2, 3, -3, 127, 0};
  for (int i = 0; i < 8; ++i) EXPECT_EQ(q[i], want_q[i]) << i;
  // Logits (scale 0.125): pixel 0 = (4, 8, -4 + 2), pixel 1 = (3, -3, 127 + 0).
  const int8_t* l = (*ex)->tensor_data(1);
  const int8_t want_l[6] = {4, 8, -2, 3, -3, 127};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(l[i], want_l[i]) << i;
  for (int p = 0; p < 2; ++p) {
    double e[3], s = 0;
    for (int c = 0; c < 3; ++c) s += e[c] = std::exp(0.125 * want_l[p * 3 + c]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(probs[p * 3 + c], e[c] / s, 1e-6) << p << " " << c;
  }
}

}  // namespace
}  // namespace ef::nn

namespace ef::nn {
namespace {

// The int8 arithmetic is integer plus IEEE float32 requantisation (no FMA, default rounding), so every
// platform gives the same logits: a golden hash of
// the tiny network's int8 head output, identical on x86-64 and AArch64 (qemu).
TEST(NnExecutor, GoldenLogitsAcrossPlatforms) {
  const Model m = load_tiny(7);
  auto ex = Executor::create(m, PlanOptions{false, false, 64});  // no reuse: every tensor stays readable
  ASSERT_TRUE(ex.ok());
  std::vector<int8_t> q((*ex)->input_floats());
  for (size_t i = 0; i < q.size(); ++i) q[i] = static_cast<int8_t>((i * 37 + 11) % 256 - 128);
  std::vector<float> p((*ex)->output_floats());
  ASSERT_TRUE((*ex)->run_quantized(q.data(), q.size(), p.data(), p.size()).ok());
  const int8_t* logits = (*ex)->tensor_data(11);
  uint32_t h = 2166136261u;  // FNV-1a
  for (size_t i = 0; i < 8 * 8 * 5; ++i) h = (h ^ uint8_t(logits[i])) * 16777619u;
  std::printf("[ golden ] tiny net logits FNV-1a = 0x%08x\n", h);
  EXPECT_EQ(h, 0x4395c419u);
  bool seen[256] = {};
  int distinct = 0;
  for (size_t i = 0; i < 8 * 8 * 5; ++i) distinct += !seen[uint8_t(logits[i])], seen[uint8_t(logits[i])] = true;
  EXPECT_GT(distinct, 20);  // not a saturated, degenerate output
}

// The whole network gives the same bytes on every kernel variant the CPU runs (each ISA cap picks
// another conv_i8 / dwconv_i8 row) and with a thread pool splitting the convolutions by rows.
TEST(NnExecutor, EveryVariantAndThreadCountGivesTheReferenceBytes) {
  const Model m = load_tiny(11);
  auto run = [&](const ExecutorOptions& o, std::vector<int8_t>* tensors, std::string* names) {
    auto ex = Executor::create(m, o);
    ASSERT_TRUE(ex.ok()) << to_string(ex.error());
    std::vector<int8_t> q((*ex)->input_floats());
    for (size_t i = 0; i < q.size(); ++i) q[i] = static_cast<int8_t>((i * 53 + 5) % 256 - 128);
    std::vector<float> p((*ex)->output_floats());
    ASSERT_TRUE((*ex)->run_quantized(q.data(), q.size(), p.data(), p.size()).ok());
    tensors->clear();
    for (uint32_t t = 1; t < m.desc.tensors.size(); ++t) {
      const int8_t* d = (*ex)->tensor_data(t);
      if (d) tensors->insert(tensors->end(), d, d + m.desc.tensors[t].elements());
    }
    names->clear();
    for (size_t l = 0; l < m.desc.layers.size(); ++l) *names += std::string((*ex)->kernel_name(l)) + " ";
  };
  ExecutorOptions ref_options;
  ref_options.plan = PlanOptions{false, false, 64};  // every tensor stays readable
  ref_options.max_isa = kernels::Isa::scalar;
  std::vector<int8_t> want, got;
  std::string names;
  run(ref_options, &want, &names);
  ASSERT_GT(want.size(), 1000u);
  ThreadPoolOptions po;
  po.threads = 3;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  for (kernels::Isa isa : {kernels::Isa::sse41, kernels::Isa::avx2, kernels::Isa::avx512vnni, kernels::Isa::neon,
                           kernels::Isa::neondot}) {
    if (!kernels::isa_available(isa)) continue;
    for (ThreadPool* p : {static_cast<ThreadPool*>(nullptr), pool->get()}) {
      ExecutorOptions o = ref_options;
      o.max_isa = isa;
      o.pool = p;
      run(o, &got, &names);
      std::printf("[ variants ] tiny net, cap %s, %d thread(s): %s\n", kernels::isa_name(isa), p ? p->threads() : 1,
                  names.c_str());
      EXPECT_EQ(got, want) << "cap " << kernels::isa_name(isa) << (p ? " with 3 threads" : "");
    }
  }
}

}  // namespace
}  // namespace ef::nn
