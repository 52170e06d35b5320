// Segmenter: what the network sees (resample_frame's pixels), what comes out (probabilities, their
// argmax, nearest-neighbour upsampling) and the sizes of each.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <vector>

#include "io/frame_resample.h"
#include "nn/executor.h"
#include "semantic/model_stats.h"
#include "semantic/segmenter.h"
#include "semantic/semantic_test_util.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef::semantic {
namespace {

// Frame `index` of a synthetic room at width x height (colour, depth, labels, a name).
Frame synthetic_frame(int width, int height, int index = 0) {
  auto src = open_source("synthetic:office?frames=8&size=" + std::to_string(width) + "x" + std::to_string(height));
  EXPECT_TRUE(src.ok()) << to_string(src.error());
  Frame f;
  for (int i = 0; i <= index; ++i) {
    auto got = (*src)->next(f);
    EXPECT_TRUE(got.ok() && *got);
  }
  return f;
}

std::unique_ptr<Segmenter> make_segmenter(const nn::Model& model, const SegmenterOptions& o = {}) {
  auto s = Segmenter::create(model, o);
  EXPECT_TRUE(s.ok()) << to_string(s.error());
  return s.ok() ? std::move(*s) : nullptr;
}

nn::Model load(const nn::ModelDesc& d) {
  auto bytes = nn::serialize_model(d);
  EXPECT_TRUE(bytes.ok()) << to_string(bytes.error());
  auto m = nn::load_model_memory(bytes->data(), bytes->size(), d.name + ".efm");
  EXPECT_TRUE(m.ok()) << to_string(m.error());
  return std::move(*m);
}

TEST(Segmenter, CreatedFromAFileWithTheModelsSizes) {
  const auto dir = test::scratch_dir("seg-file");
  const auto path = test::write_tiny_seg_model(dir);
  auto s = Segmenter::create(path.string());
  ASSERT_TRUE(s.ok()) << to_string(s.error());
  Segmenter& seg = **s;
  EXPECT_EQ(seg.input_width(), 32);
  EXPECT_EQ(seg.input_height(), 24);
  EXPECT_EQ(seg.output_width(), 16);
  EXPECT_EQ(seg.output_height(), 12);
  EXPECT_EQ(seg.num_classes(), 14);
  EXPECT_EQ(seg.input().size(), 24u * 32u * 4u);
  EXPECT_EQ(seg.probabilities().floats(), 12u * 16u * 14u);
  EXPECT_EQ(seg.labels().width, 16);
  EXPECT_EQ(seg.labels().height, 12);
  EXPECT_EQ(seg.model().desc.name, "tiny-seg");
  EXPECT_GT(seg.buffer_bytes(), 0u);

  Frame f = synthetic_frame(320, 240);
  Image<uint8_t> full(320, 240);
  ASSERT_TRUE(seg.segment(f, full.view()).ok());
  EXPECT_GT(seg.last_timings().forward_ms, 0.0);
  EXPECT_GT(seg.last_timings().resample_ms, 0.0);
  EXPECT_GE(seg.last_timings().total_ms, seg.last_timings().forward_ms);
}

TEST(Segmenter, MissingAndUnsuitableModelsAreErrors) {
  auto missing = Segmenter::create("/nonexistent/edgefusion-seg.efm");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_NE(missing.error().message.find("/nonexistent/edgefusion-seg.efm"), std::string::npos);

  const nn::Model two = load(test::tiny_seg_net(24, 32, 14, 5, /*in_channels=*/2));
  auto s = Segmenter::create(two);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(s.error().message.find("3 (R, G, B) or 4 (R, G, B, depth)"), std::string::npos) << s.error().message;
}

// Issue 28: a network trained on photographs takes R, G, B only.
TEST(Segmenter, RgbOnlyNetworkReadsTheColourAlone) {
  const nn::Model model = load(test::tiny_seg_net(24, 32, 14, 5, /*in_channels=*/3));
  auto seg = make_segmenter(model);
  ASSERT_TRUE(seg);
  const Frame f = synthetic_frame(32, 24);
  ASSERT_TRUE(seg->segment(f).ok());
  ASSERT_EQ(seg->input().size(), std::size_t(32 * 24 * 3));
  for (int k : {0, 17, 32 * 24 - 1}) {
    const Rgb8 c = f.color.data()[k];
    EXPECT_EQ(seg->input()[std::size_t(3 * k)], float(c.r));
    EXPECT_EQ(seg->input()[std::size_t(3 * k + 1)], float(c.g));
    EXPECT_EQ(seg->input()[std::size_t(3 * k + 2)], float(c.b));
  }
}

// Issue 28: with a class map in the model (e.g. ADE20K's 151 outputs -> the NYUv2 13), the
// probabilities are the target classes', each the sum of its source classes'.
TEST(Segmenter, ClassMapSumsTheSourceProbabilities) {
  nn::ModelDesc plain = test::tiny_seg_net(24, 32, 6);
  nn::ModelDesc mapped = plain;
  mapped.class_map = {0, 2, 1, 2, 2, 0};
  mapped.target_class_names = {"unknown", "b", "c"};
  const nn::Model a = load(plain), b = load(mapped);
  auto net = make_segmenter(a);
  auto seg = make_segmenter(b);
  ASSERT_TRUE(net && seg);
  EXPECT_EQ(seg->num_classes(), 3);
  EXPECT_EQ(seg->class_name(2), "c");
  const Frame f = synthetic_frame(64, 48);
  ASSERT_TRUE(net->segment(f).ok());
  ASSERT_TRUE(seg->segment(f).ok());
  const ProbabilityView p = net->probabilities(), q = seg->probabilities();
  ASSERT_EQ(q.classes, 3);
  ASSERT_EQ(q.width, p.width);
  for (int y = 0; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x) {
      const float* s = p.pixel(x, y);
      const float* t = q.pixel(x, y);
      EXPECT_EQ(t[0], s[0] + s[5]);
      EXPECT_EQ(t[1], s[2]);
      EXPECT_EQ(t[2], (s[1] + s[3]) + s[4]);
      EXPECT_NEAR(t[0] + t[1] + t[2], 1.0f, 1e-5f);
      const int want = int(std::max_element(t, t + 3) - t);
      EXPECT_EQ(seg->labels()(x, y), want);
    }
}

TEST(Segmenter, FramesWithoutColourOrDepthAreRejected) {
  const nn::Model model = load(test::tiny_seg_net(24, 32));
  auto seg = make_segmenter(model);
  ASSERT_TRUE(seg);
  Frame f;
  f.depth.allocate(32, 24);
  f.name = "frame-7";
  const Status s = seg->segment(f);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(s.error().message.find("frame-7"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("no colour"), std::string::npos) << s.error().message;
  f.color.allocate(30, 24);
  EXPECT_FALSE(seg->segment(f).ok());
}

// A 640x480 frame reaches the network as resample_frame makes it (the `convert --resolution` path),
// and the probabilities are the executor's on exactly that input. Also the other shrink paths: by 2
// (the vector path of OpenCV's area resize), by 20 (too large for resizing in strips) and by a
// non-integer factor.
TEST(Segmenter, ResamplesA640x480FrameToTheModelInputLikeConvert) {
  struct Case {
    int frame_w, frame_h;
    uint32_t model_h, model_w;
  };
  for (const Case c : {Case{640, 480, 120, 160}, Case{320, 240, 120, 160}, Case{640, 480, 24, 32},
                       Case{300, 200, 24, 32}}) {
    SCOPED_TRACE(std::to_string(c.frame_w) + "x" + std::to_string(c.frame_h) + " -> " + std::to_string(c.model_w) +
                 "x" + std::to_string(c.model_h));
    const nn::Model model = load(test::tiny_seg_net(c.model_h, c.model_w));
    auto seg = make_segmenter(model);
    ASSERT_TRUE(seg);
    Frame f = synthetic_frame(c.frame_w, c.frame_h, 2);
    const int mw = int(c.model_w), mh = int(c.model_h);
    Frame want;
    want.allocate(mw, mh, false);
    // The rendered room, then random colour bytes (every rounding case of the area average).
    std::mt19937 rng(7);
    for (int pass = 0; pass < 2; ++pass) {
      if (pass == 1)
        for (std::size_t i = 0; i < f.color.size(); ++i)
          f.color.data()[i] = Rgb8{uint8_t(rng()), uint8_t(rng()), uint8_t(rng())};
      ASSERT_TRUE(seg->segment(f).ok());
      resample_frame(f, want);
      const std::vector<float>& in = seg->input();
      ASSERT_EQ(in.size(), std::size_t(mw) * std::size_t(mh) * 4u);
      std::size_t mismatches = 0;
      for (int y = 0; y < mh; ++y)
        for (int x = 0; x < mw; ++x) {
          const float* p = &in[(std::size_t(y) * std::size_t(mw) + std::size_t(x)) * 4];
          const Rgb8 col = want.color(x, y);
          mismatches +=
              p[0] != float(col.r) || p[1] != float(col.g) || p[2] != float(col.b) || p[3] != want.depth(x, y);
        }
      EXPECT_EQ(mismatches, 0u) << "pass " << pass;
    }
    const std::vector<float>& in = seg->input();

    auto ex = nn::Executor::create(model);
    ASSERT_TRUE(ex.ok());
    std::vector<float> probs((*ex)->output_floats());
    ASSERT_TRUE((*ex)->run(in.data(), in.size(), probs.data(), probs.size()).ok());
    const ProbabilityView p = seg->probabilities();
    ASSERT_EQ(p.floats(), probs.size());
    EXPECT_EQ(std::memcmp(p.data, probs.data(), probs.size() * sizeof(float)), 0);
  }
}

// A frame that already has the input size is used as it is.
TEST(Segmenter, AFrameAtTheInputSizeIsNotResampled) {
  const nn::Model model = load(test::tiny_seg_net(24, 32));
  auto seg = make_segmenter(model);
  ASSERT_TRUE(seg);
  const Frame f = synthetic_frame(32, 24);
  ASSERT_TRUE(seg->segment(f).ok());
  EXPECT_EQ(seg->last_timings().resample_ms, 0.0);
  const std::vector<float>& in = seg->input();
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      const float* p = &in[(std::size_t(y) * 32 + std::size_t(x)) * 4];
      ASSERT_EQ(p[0], float(f.color(x, y).r));
      ASSERT_EQ(p[3], f.depth(x, y));
    }
}

TEST(Segmenter, LabelsAreTheArgmaxOfTheProbabilities) {
  const nn::Model model = load(test::tiny_seg_net(120, 160));
  auto seg = make_segmenter(model);
  ASSERT_TRUE(seg);
  std::set<int> seen;
  for (int index : {0, 4}) {
    ASSERT_TRUE(seg->segment(synthetic_frame(320, 240, index)).ok());
    const ProbabilityView p = seg->probabilities();
    ASSERT_EQ(p.height, 60);
    ASSERT_EQ(p.width, 80);
    ASSERT_EQ(p.classes, 14);
    for (int y = 0; y < p.height; ++y)
      for (int x = 0; x < p.width; ++x) {
        const float* px = p.pixel(x, y);
        int best = 0;
        double sum = 0;
        for (int k = 0; k < p.classes; ++k) {
          sum += px[k];
          if (px[k] > px[best]) best = k;  // the first of equal maxima
        }
        ASSERT_NEAR(sum, 1.0, 1e-5) << x << "," << y;
        ASSERT_EQ(int(seg->labels()(x, y)), best) << x << "," << y;
        seen.insert(best);
      }
  }
  EXPECT_GE(seen.size(), 2u);  // the premise: the random network does not answer one class everywhere
}

// out(x, y) = labels(floor((x + 0.5) * W' / W), floor((y + 0.5) * H' / H)) at any size.
TEST(Segmenter, ClassIdsAreUpsampledByNearestNeighbourToAnySize) {
  const nn::Model model = load(test::tiny_seg_net(24, 32, 14, 9));
  auto seg = make_segmenter(model);
  ASSERT_TRUE(seg);
  const Frame f = synthetic_frame(640, 480, 1);
  Image<uint8_t> full(640, 480);
  ASSERT_TRUE(seg->segment(f, full.view()).ok());
  const auto l = seg->labels();
  for (auto [w, h] : {std::pair<int, int>{640, 480}, {16, 12}, {37, 11}, {100, 75}, {5, 3}}) {
    Image<uint8_t> out(w, h);
    out.fill(255);
    if (w == 640) out = full;
    else seg->upsample_labels(out.view());
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int xs = int(std::floor((x + 0.5) * l.width / w)), ys = int(std::floor((y + 0.5) * l.height / h));
        ASSERT_EQ(out(x, y), l(xs, ys)) << w << "x" << h << " at " << x << "," << y;
      }
  }
  // A strided view (a sub-rectangle) is written row by row, nothing outside it.
  Image<uint8_t> big(50, 40);
  big.fill(200);
  seg->upsample_labels(big.view().sub(5, 5, 32, 24));
  EXPECT_EQ(big(4, 5), 200);
  EXPECT_EQ(big(37, 5), 200);
  EXPECT_EQ(big(5, 29), 200);
  EXPECT_EQ(big(5, 5), l(0, 0));
}

// Every kernel level and a thread pool give the same bytes (the kernels are bit-exact).
TEST(Segmenter, EveryIsaAndAPoolGiveTheSameResult) {
  const nn::Model model = load(test::tiny_seg_net(120, 160, 14, 3));
  const Frame f = synthetic_frame(640, 480, 3);
  SegmenterOptions scalar;
  scalar.max_isa = kernels::Isa::scalar;
  auto ref = make_segmenter(model, scalar);
  ASSERT_TRUE(ref && ref->segment(f).ok());
  EXPECT_EQ(kernel_isa_summary(ref->executor(), model.desc.layers.size()), "scalar");
  ThreadPoolOptions po;
  po.threads = 2;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  SegmenterOptions pooled;
  pooled.pool = pool->get();
  for (const SegmenterOptions& o : {SegmenterOptions{}, pooled}) {
    auto seg = make_segmenter(model, o);
    ASSERT_TRUE(seg && seg->segment(f).ok());
    const ProbabilityView a = ref->probabilities(), b = seg->probabilities();
    EXPECT_EQ(std::memcmp(a.data, b.data, a.floats() * sizeof(float)), 0);
  }
}

TEST(Segmenter, IsaNamesParse) {
  EXPECT_EQ(*parse_isa("avx2", "--isa"), kernels::Isa::avx2);
  EXPECT_EQ(*parse_isa("scalar", "--isa"), kernels::Isa::scalar);
  EXPECT_EQ(*parse_isa("neondot", "--isa"), kernels::Isa::neondot);
  auto bad = parse_isa("avx3", "--isa");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("avx3"), std::string::npos);
  EXPECT_NE(bad.error().message.find("--isa"), std::string::npos);
}

// MACs: out_h * out_w * cout * kh * kw * cin_per_group per convolution; parameters: weights + biases.
TEST(ModelStats, CountsMacsAndParametersOfConvolutions) {
  const ModelStats s = compute_model_stats(test::tiny_seg_net(24, 32));
  EXPECT_EQ(s.conv_layers, 2);
  EXPECT_EQ(s.macs, 12u * 16 * 8 * 3 * 3 * 4 + 12u * 16 * 14 * 8);
  EXPECT_EQ(s.parameters, (8u * 36 + 8) + (14u * 8 + 14));
  EXPECT_EQ(s.weight_bytes, (8u * 36 + 8 * 8) + (14u * 8 + 14 * 8));
  ASSERT_EQ(s.layers.size(), 3u);
  EXPECT_EQ(s.layers[2].macs, 0u);
  // With a depthwise layer (cin_per_group 1), a dilated head and layers without weights.
  const ModelStats t = compute_model_stats(test::tiny_net());
  EXPECT_EQ(t.conv_layers, 4);
  EXPECT_EQ(t.macs, 8u * 8 * 8 * 9 * 4 + 4u * 4 * 8 * 9 + 4u * 4 * 8 * 8 + 8u * 8 * 5 * 9 * 16);
  EXPECT_EQ(t.parameters, (8u * 36 + 8) + (8u * 9 + 8) + (8u * 8 + 8) + (5u * 144 + 5));
}

}  // namespace
}  // namespace ef::semantic
