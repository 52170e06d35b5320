// resize_bilinear_i8 and global average pooling, the two layer kinds a DeepLabv3 head needs.
//
// resize: the integer rule itself on hand-computed cases (2x2 -> 3x3, taps of 3 -> 4 and 33 -> 65),
// its agreement with TensorFlow's float align_corners resize (within one step), then every variant
// the CPU runs against resize_bilinear_i8_ref byte for byte: the DeepLab shapes (1x1 -> 33x33 and
// 65x65 broadcasts, 65x65 -> 129x129, 33x33 -> 65x65, 17x25 -> 33x49, 20x20 -> 33x33, 33x33 -> 17x17
// down) with channels 1, 3, 16, 48, 151, 256, 304, channels 1..70 around every block width on random
// up / down / 1-pixel shapes, and inputs at -128 / 127 / alternating extremes (the largest sums).
// Variants read the loader's taps (PreparedLayer::resize_taps, built here the same way with
// resize_tap); the reference recomputes them. Tensors live in exact-size heap buffers, so any read or
// write past one is a heap overflow under ASan.
//
// global average pool: every avgpool variant against avgpool_i8_ref on 33x33x320 and 65x65x320
// windows (the DeepLab image pooling at 257 and 513 inputs) with the loader's one-entry multiplier
// table, plus 256x256 (the limit) and extremes. Last, a DeepLab-head-shaped network through the
// executor at every ISA cap, with and without a thread pool: every int8 tensor and probability bit as
// at Isa::scalar, and no heap allocation per run.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/thread_pool.h"
#include "kernels/kernel_test_util.h"
#include "nn/eltwise_kernels.h"
#include "nn/executor.h"
#include "nn/nn_test_util.h"
#include "support/alloc_counter.h"
#include "test_support.h"

namespace ef::nn {
namespace {

using ResizeVariant = kernels::KernelVariant<ResizeI8Fn>;
using PoolVariant = kernels::KernelVariant<PoolI8Fn>;

const std::vector<const ResizeVariant*>& resize_variants() {
  static const std::vector<const ResizeVariant*> v =
      ef::test::runnable_variants(kResizeBilinearI8Variants, "resize_bilinear_i8");
  return v;
}
const std::vector<const PoolVariant*>& avg_pool_variants() {
  static const std::vector<const PoolVariant*> v = ef::test::runnable_variants(kAvgPoolI8Variants, "avgpool_i8");
  return v;
}

using ef::test::Fill;
using ef::test::make_input;

// The loader's taps: out_h row taps, then out_w column taps.
std::vector<ResizeTap> taps_for(int in_h, int in_w, int out_h, int out_w) {
  std::vector<ResizeTap> t(std::size_t(out_h) + out_w);
  for (int o = 0; o < out_h; ++o) t[o] = resize_tap(o, in_h, out_h);
  for (int o = 0; o < out_w; ++o) t[out_h + o] = resize_tap(o, in_w, out_w);
  return t;
}

std::vector<int8_t> run_ref(const std::vector<int8_t>& in, int h, int w, int c, int oh, int ow) {
  ResizeArgs a;
  a.in = TensorI8{in.data(), h, w, c, 3};
  std::vector<int8_t> out(std::size_t(oh) * ow * c);
  a.out = MutTensorI8{out.data(), oh, ow, c, 3};
  resize_bilinear_i8_ref(a);  // recomputes its taps: taps_y / taps_x stay null
  return out;
}

// ------------------------------------------------------------------------------------ the rule itself

TEST(ResizeBilinearRule, TapsByHand) {
  // 3 -> 4: source positions 0, 2/3, 4/3, 2: weights 2/3 * 2048 = 1365.3 -> 1365, 1/3 * 2048 -> 683.
  const ResizeTap t1 = resize_tap(1, 3, 4), t2 = resize_tap(2, 3, 4), t3 = resize_tap(3, 3, 4);
  EXPECT_EQ(t1.i0, 0); EXPECT_EQ(t1.i1, 1); EXPECT_EQ(t1.w, 1365);
  EXPECT_EQ(t2.i0, 1); EXPECT_EQ(t2.i1, 2); EXPECT_EQ(t2.w, 683);
  EXPECT_EQ(t3.i0, 2); EXPECT_EQ(t3.i1, 2); EXPECT_EQ(t3.w, 0);
  // 33 -> 65 (the DeepLab decoder at 257): every odd output halfway, every even one on a pixel.
  for (int o = 0; o < 65; ++o) {
    const ResizeTap t = resize_tap(o, 33, 65);
    EXPECT_EQ(t.i0, o / 2);
    EXPECT_EQ(t.w, o % 2 ? 1024 : 0);
    EXPECT_EQ(t.i1, std::min(o / 2 + 1, 32));
  }
  // 1 -> m (broadcast) and n -> 1 (the first pixel, as TensorFlow with align_corners).
  for (int o = 0; o < 33; ++o) {
    const ResizeTap t = resize_tap(o, 1, 33);
    EXPECT_EQ(t.i0, 0); EXPECT_EQ(t.i1, 0); EXPECT_EQ(t.w, 0);
  }
  const ResizeTap one = resize_tap(0, 17, 1);
  EXPECT_EQ(one.i0, 0); EXPECT_EQ(one.i1, 0); EXPECT_EQ(one.w, 0);
  // Down 33 -> 17: output o at source 2o, always on a pixel.
  for (int o = 0; o < 17; ++o) {
    const ResizeTap t = resize_tap(o, 33, 17);
    EXPECT_EQ(t.i0, 2 * o); EXPECT_EQ(t.w, 0);
  }
  // The largest sizes: weights stay within [0, 2048].
  for (int o = 0; o < 8192; o += 7) {
    const ResizeTap t = resize_tap(o, 8192, 8192 - 3);
    EXPECT_GE(t.w, 0); EXPECT_LE(t.w, kResizeOne); EXPECT_LT(t.i1, 8192);
  }
}

TEST(ResizeBilinearRule, HandComputed2x2To3x3) {
  // u = q + 128: [[0, 255], [128, 178]]. Taps along both axes: (0, 0, 0), (0, 1, 1024), (1, 1, 0).
  // Centre: (0 + 255 + 128 + 178) / 4 = 140.25 -> 140; edge midpoints 127.5 -> 128 and 216.5 -> 217
  // (round half up), 64 and 153 exactly; corners copied.
  const std::vector<int8_t> in = {-128, 127, 0, 50};
  const std::vector<int8_t> want = {-128, 0, 127,   //  u 0, 128, 255
                                    -64, 12, 89,    //  u 64, 140, 217
                                    0, 25, 50};     //  u 128, 153, 178
  EXPECT_EQ(run_ref(in, 2, 2, 1, 3, 3), want);
  const std::vector<ResizeTap> taps = taps_for(2, 2, 3, 3);
  for (const ResizeVariant* v : resize_variants()) {
    ResizeArgs a;
    a.in = TensorI8{in.data(), 2, 2, 1, 0};
    std::vector<int8_t> got(9, 0x55);
    a.out = MutTensorI8{got.data(), 3, 3, 1, 0};
    a.taps_y = taps.data();
    a.taps_x = taps.data() + 3;
    v->fn(a);
    EXPECT_EQ(got, want) << v->name;
  }
}

// TensorFlow's float resize (align_corners=True, half_pixel_centers=False) on the dequantised-free
// values u: the integer rule is within one step of round(float) (11-bit weights: the error before
// rounding is below 2 * 255 / 4096 + 1/2).
TEST(ResizeBilinearRule, WithinOneStepOfTensorFlowFloat) {
  std::mt19937 rng(90);
  for (const std::array<int, 4>& size : {std::array<int, 4>{17, 25, 33, 49}, {3, 5, 7, 4}, {20, 20, 33, 33}, {33, 33, 17, 17}}) {
    // Plain ints, not a structured binding: C++17 lambdas cannot capture a binding (clang refuses).
    const int h = size[0], w = size[1], oh = size[2], ow = size[3];
    const int c = 3;
    const std::vector<int8_t> in = make_input(std::size_t(h) * w * c, Fill::kRandom, rng);
    const std::vector<int8_t> got = run_ref(in, h, w, c, oh, ow);
    auto src = [](int o, int n, int m) { return m > 1 ? double(o) * (n - 1) / (m - 1) : 0.0; };
    for (int oy = 0; oy < oh; ++oy)
      for (int ox = 0; ox < ow; ++ox) {
        const double sy = src(oy, h, oh), sx = src(ox, w, ow);
        const int y0 = int(std::floor(sy)), x0 = int(std::floor(sx));
        const int y1 = std::min(y0 + 1, h - 1), x1 = std::min(x0 + 1, w - 1);
        const double ly = sy - y0, lx = sx - x0;
        for (int k = 0; k < c; ++k) {
          auto q = [&](int y, int x) { return double(in[(std::size_t(y) * w + x) * c + k]); };
          const double top = q(y0, x0) + (q(y0, x1) - q(y0, x0)) * lx;
          const double bottom = q(y1, x0) + (q(y1, x1) - q(y1, x0)) * lx;
          const double want = top + (bottom - top) * ly;
          EXPECT_LE(std::abs(double(got[(std::size_t(oy) * ow + ox) * c + k]) - std::round(want)), 1.0)
              << h << "x" << w << " -> " << oh << "x" << ow << " at " << oy << "," << ox << "," << k;
        }
      }
  }
}

// ------------------------------------------------------------------------------------------ variants

void check_resize(int h, int w, int c, int oh, int ow, std::mt19937& rng, Fill fill = Fill::kRandom) {
  const std::vector<int8_t> in = make_input(std::size_t(h) * w * c, fill, rng);
  const std::vector<int8_t> want = run_ref(in, h, w, c, oh, ow);
  const std::vector<ResizeTap> taps = taps_for(h, w, oh, ow);
  ResizeArgs a;
  a.in = TensorI8{in.data(), h, w, c, 3};
  a.taps_y = taps.data();
  a.taps_x = taps.data() + oh;
  for (const ResizeVariant* v : resize_variants()) {
    SCOPED_TRACE(std::string(v->name) + " " + std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c) +
                 " -> " + std::to_string(oh) + "x" + std::to_string(ow) + " fill " + std::to_string(int(fill)));
    std::vector<int8_t> got(want.size(), 0x55);
    a.out = MutTensorI8{got.data(), oh, ow, c, 3};
    v->fn(a);
    ASSERT_EQ(got, want);
  }
}

struct Shape {
  int h, w, oh, ow;
  std::vector<int> channels;
};

TEST(ResizeBilinearVariants, DeepLabShapes) {
  std::mt19937 rng(91);
  const std::vector<Shape> shapes = {
      {1, 1, 33, 33, {1, 3, 256, 304}},             // image pooling broadcast at 257
      {1, 1, 65, 65, {16, 151, 256}},               // ... at 513
      {65, 65, 129, 129, {3, 48, 151}},
      {33, 33, 65, 65, {1, 16, 256, 304}},
      {17, 25, 33, 49, {1, 3, 16, 48, 151, 256, 304}},
      {20, 20, 33, 33, {3, 48, 151}},
      {33, 33, 17, 17, {1, 16, 151, 304}},          // down
  };
  for (const Shape& s : shapes)
    for (int c : s.channels) check_resize(s.h, s.w, c, s.oh, s.ow, rng);
}

TEST(ResizeBilinearVariants, ChannelsAroundEveryBlockWidth) {
  std::mt19937 rng(92);
  std::uniform_int_distribution<int> hw(1, 9);
  for (int c = 1; c <= 70; ++c) {
    check_resize(hw(rng), hw(rng), c, hw(rng) + 3, hw(rng) + 3, rng);  // mostly up
    check_resize(hw(rng) + 5, hw(rng) + 5, c, hw(rng), hw(rng), rng);  // mostly down
  }
  for (int c : {127, 128, 129, 191, 255, 257, 300})
    check_resize(5, 4, c, 9, 7, rng);
}

TEST(ResizeBilinearVariants, DegenerateAxes) {
  std::mt19937 rng(93);
  for (int c : {1, 7, 16, 33, 64, 65}) {
    check_resize(1, 1, c, 1, 1, rng);    // identity
    check_resize(1, 7, c, 5, 13, rng);   // one input row: rows broadcast
    check_resize(6, 1, c, 11, 4, rng);   // one input column
    check_resize(9, 8, c, 1, 1, rng);    // -> 1x1: the first pixel
    check_resize(9, 8, c, 1, 15, rng);   // one output row
    check_resize(5, 5, c, 5, 5, rng);    // same size: a copy
    check_resize(2, 3, c, 40, 1, rng);
  }
}

TEST(ResizeBilinearVariants, Extremes) {
  std::mt19937 rng(94);
  for (int c : {1, 8, 14, 16, 31, 64, 65, 151})
    for (Fill fill : {Fill::kMin, Fill::kMax, Fill::kAlternate}) {
      check_resize(4, 5, c, 9, 11, rng, fill);
      check_resize(9, 11, c, 4, 5, rng, fill);
    }
}

TEST(ResizeBilinearVariants, RandomSizes) {
  std::mt19937 rng(95);
  std::uniform_int_distribution<int> hw(1, 24), ch(1, 80);
  for (int it = 0; it < 120; ++it) check_resize(hw(rng), hw(rng), ch(rng), hw(rng), hw(rng), rng);
}

// -------------------------------------------------------------------------------- global average pool

// Every avgpool variant on a global pool of h x w x c with the loader's one-entry table
// (requant_count_base = h * w).
void check_global_pool(int h, int w, int c, int32_t zi, int32_t zo, double ratio, std::mt19937& rng,
                       Fill fill = Fill::kRandom) {
  const std::vector<int8_t> in = make_input(std::size_t(h) * w * c, fill, rng);
  const Requant rq{static_cast<float>(ratio / double(h * w))};
  PoolArgs p;
  p.in = TensorI8{in.data(), h, w, c, zi};
  p.kernel_h = h;
  p.kernel_w = w;
  p.requant_by_count = &rq;
  p.requant_count_base = h * w;
  std::vector<int8_t> want(static_cast<std::size_t>(c));
  p.out = MutTensorI8{want.data(), 1, 1, c, zo};
  avgpool_i8_ref(p);
  // The reference is the mean: check it against a plain double average (within one step).
  for (int k = 0; k < c && fill == Fill::kRandom; ++k) {
    double sum = 0;
    for (int i = 0; i < h * w; ++i) sum += in[std::size_t(i) * c + k] - zi;
    const double mean = std::clamp(sum * ratio / (h * w) + zo, -128.0, 127.0);
    EXPECT_LE(std::abs(want[k] - mean), 1.0) << "channel " << k;
  }
  for (const PoolVariant* v : avg_pool_variants()) {
    SCOPED_TRACE(std::string(v->name) + " global " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                 std::to_string(c) + " zi " + std::to_string(zi) + " zo " + std::to_string(zo));
    std::vector<int8_t> got(want.size(), 0x55);
    p.out.data = got.data();
    v->fn(p);
    ASSERT_EQ(got, want);
  }
}

TEST(GlobalAvgPoolVariants, DeepLabImagePooling) {
  std::mt19937 rng(96);
  std::uniform_int_distribution<int> zp(-128, 127);
  for (int side : {33, 65}) {
    check_global_pool(side, side, 320, zp(rng), zp(rng), 1.0, rng);
    check_global_pool(side, side, 320, zp(rng), zp(rng), 0.37, rng);
    check_global_pool(side, side, 320, -128, 127, 1.0, rng, Fill::kMax);   // the largest positive sums
    check_global_pool(side, side, 320, 127, -128, 1.0, rng, Fill::kMin);   // the largest negative sums
  }
}

TEST(GlobalAvgPoolVariants, ChannelsAndTheLimit) {
  std::mt19937 rng(97);
  std::uniform_int_distribution<int> zp(-128, 127);
  for (int c : {1, 3, 15, 16, 17, 33, 64, 65, 151})
    check_global_pool(40, 37, c, zp(rng), zp(rng), 2.5, rng);
  // 256 x 256, the loader's limit: sums up to 255 * 65536.
  check_global_pool(256, 256, 17, -128, 0, 1.0, rng, Fill::kMax);
  check_global_pool(256, 256, 17, 127, 0, 1.0, rng, Fill::kMin);
  if (!test::kUnderEmulator) check_global_pool(256, 256, 64, zp(rng), zp(rng), 1.0, rng);
}

// ---------------------------------------------------------------------------------------- executor

// The DeepLabv3 head at a 257 input, shrunk in channels:
//   t0 33x33x8 -pw-> t1 33x33x24 -global avg-> t2 1x1x24 -pw-> t3 1x1x16 -resize-> t4 33x33x16 (broadcast)
//   t0 -pw-> t5 33x33x16; concat(t4, t5) -> t6 33x33x32 -pw-> t7 33x33x7 -resize-> t8 65x65x7
//   -resize (down)-> t9 17x25x7 -softmax-> t10 (float)
ModelDesc deeplab_head(uint32_t classes = 7) {
  using test::layer;
  using test::tensor;
  std::mt19937 rng(98);
  ModelDesc d;
  d.name = "deeplab-head";
  d.input_mean.assign(8, 0.0f);
  d.input_scale.assign(8, 1.0f / 32);
  for (uint32_t k = 0; k < classes; ++k) d.class_names.push_back("c" + std::to_string(k));
  d.tensors = {tensor(33, 33, 8, 0.03f, -3),      tensor(33, 33, 24, 0.05f, 4),  tensor(1, 1, 24, 0.02f, -9),
               tensor(1, 1, 16, 0.06f, 2),        tensor(33, 33, 16, 0.06f, 2),  tensor(33, 33, 16, 0.06f, 2),
               tensor(33, 33, 32, 0.06f, 2),      tensor(33, 33, classes, 0.11f, -7),
               tensor(65, 65, classes, 0.11f, -7), tensor(17, 25, classes, 0.11f, -7), test::float_tensor(17, 25, classes)};
  d.input_tensor = 0;
  d.output_tensor = 10;
  auto pw1 = layer(LayerType::kPointwiseConv2d, {0}, 1);
  test::fill_weights(pw1, 24, 8, rng);
  auto gap = layer(LayerType::kAvgPool, {1}, 2);
  gap.kernel_h = gap.kernel_w = 33;  // above kMaxKernel: allowed as a global pool
  auto pw2 = layer(LayerType::kPointwiseConv2d, {2}, 3);
  test::fill_weights(pw2, 16, 24, rng);
  auto bcast = layer(LayerType::kResizeBilinear, {3}, 4);
  auto pw3 = layer(LayerType::kPointwiseConv2d, {0}, 5);
  test::fill_weights(pw3, 16, 8, rng);
  auto cat = layer(LayerType::kConcat, {4, 5}, 6);
  auto pw4 = layer(LayerType::kPointwiseConv2d, {6}, 7);
  test::fill_weights(pw4, classes, 32, rng);
  auto up = layer(LayerType::kResizeBilinear, {7}, 8);
  auto down = layer(LayerType::kResizeBilinear, {8}, 9);
  auto sm = layer(LayerType::kSoftmax, {9}, 10);
  d.layers = {pw1, gap, pw2, bcast, pw3, cat, pw4, up, down, sm};
  return d;
}

TEST(ResizeExecutor, DeepLabHeadGivesTheReferenceBitsAtEveryCap) {
  auto bytes = serialize_model(deeplab_head());
  ASSERT_TRUE(bytes.ok()) << to_string(bytes.error());
  auto model = load_model_memory(bytes->data(), bytes->size(), "head.efm");
  ASSERT_TRUE(model.ok()) << to_string(model.error());
  const Model& m = *model;
  EXPECT_EQ(m.prepared[1].requant.size(), 1u);                  // the global pool's one multiplier
  EXPECT_EQ(m.prepared[7].resize_taps.size(), std::size_t(65 + 65));
  std::vector<int8_t> input(33 * 33 * 8);
  std::mt19937 rng(99);
  for (auto& q : input) q = static_cast<int8_t>(rng());
  auto run = [&](kernels::Isa cap, ThreadPool* pool, std::vector<int8_t>* tensors, std::vector<uint32_t>* bits,
                 std::string* names) {
    ExecutorOptions o;
    o.plan = PlanOptions{false, true, 64};
    o.max_isa = cap;
    o.pool = pool;
    auto ex = Executor::create(m, o);
    ASSERT_TRUE(ex.ok()) << to_string(ex.error());
    std::vector<float> probs((*ex)->output_floats());
    ASSERT_TRUE((*ex)->run_quantized(input.data(), input.size(), probs.data(), probs.size()).ok());
    bits->resize(probs.size());
    std::memcpy(bits->data(), probs.data(), probs.size() * sizeof(float));
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
  EXPECT_NE(names.find("resize_bilinear_i8_ref"), std::string::npos) << names;
  // The broadcast tensor t4 is t3 repeated at every pixel.
  const std::size_t t4_at = m.desc.tensors[1].elements() + m.desc.tensors[2].elements() + m.desc.tensors[3].elements();
  for (std::size_t px = 0; px < 33 * 33; ++px)
    ASSERT_EQ(std::memcmp(want.data() + t4_at + px * 16, want.data() + t4_at - 16, 16), 0) << "pixel " << px;
  ThreadPoolOptions po;
  po.threads = 2;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  for (kernels::Isa isa : {kernels::Isa::sse41, kernels::Isa::avx2, kernels::Isa::avx512vnni, kernels::Isa::neon,
                           kernels::Isa::neondot}) {
    if (!kernels::isa_available(isa)) continue;
    for (ThreadPool* p : {static_cast<ThreadPool*>(nullptr), pool->get()}) {
      run(isa, p, &got, &got_bits, &names);
      std::printf("[ variants ] deeplab head, cap %s, %d thread(s): %s\n", kernels::isa_name(isa),
                  p ? p->threads() : 1, names.c_str());
      EXPECT_EQ(got, want) << "int8 tensors, cap " << kernels::isa_name(isa);
      EXPECT_EQ(got_bits, want_bits) << "probabilities, cap " << kernels::isa_name(isa);
    }
  }
}

TEST(ResizeExecutor, RunAllocatesNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  auto bytes = serialize_model(deeplab_head());
  ASSERT_TRUE(bytes.ok());
  auto model = load_model_memory(bytes->data(), bytes->size(), "head.efm");
  ASSERT_TRUE(model.ok());
  auto ex = Executor::create(*model);
  ASSERT_TRUE(ex.ok());
  std::vector<float> in((*ex)->input_floats(), 0.5f), out((*ex)->output_floats());
  ASSERT_TRUE((*ex)->run(in.data(), in.size(), out.data(), out.size()).ok());  // warm-up
  test::AllocationCounter count;
  for (int i = 0; i < 3; ++i) {
    in[std::size_t(i)] = float(i);
    EXPECT_TRUE((*ex)->run(in.data(), in.size(), out.data(), out.size()).ok());
  }
  EXPECT_EQ(count.thread_allocations(), 0u);
}

}  // namespace
}  // namespace ef::nn
