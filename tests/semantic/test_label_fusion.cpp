// LabelFusion::fuse on a small hand-built pool and index map: exactly the visible surfels are
// updated, each with the CNN pixel the nearest-neighbour rule gives; labels travel with surfels
// when the pool copies or removes them; merged surfels multiply their distributions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/image.h"
#include "semantic/label_fusion.h"
#include "semantic/label_store.h"
#include "slam/index_map.h"
#include "slam/surfel_fusion.h"
#include "slam/surfel_pool.h"

namespace ef::semantic {
namespace {

slam::SurfelPool make_pool(int n) {
  slam::SurfelPoolOptions o;
  o.capacity = 64;
  auto pool = slam::SurfelPool::create(o);
  EXPECT_TRUE(pool.ok());
  for (int i = 0; i < n; ++i) EXPECT_EQ(pool->append(0, 0, 1, 0, 0, -1, 0.01f, 1, 0, 0), i);
  return std::move(*pool);
}

// What a fuse needs: a LabelFusion for a W x H working image and a Wc x Hc CNN output (still to be
// checked with ok()), a pool of `surfels` surfels with uniform labels, and an index map of `scale`
// index pixels per working pixel along each axis with no surfel in any cell.
struct FusionMap {
  Result<LabelFusion> fusion;
  slam::SurfelPool pool;
  slam::IndexMap index;
};

FusionMap make_fusion_map(int W, int H, int Wc, int Hc, int scale, int surfels) {
  LabelFusionOptions opt;
  opt.working_width = W;
  opt.working_height = H;
  opt.cnn_width = Wc;
  opt.cnn_height = Hc;
  FusionMap m{LabelFusion::create(opt), make_pool(surfels), {}};
  m.index.scale = scale;
  m.index.id.allocate(W * scale, H * scale);
  m.index.id.fill(-1);
  return m;
}

// CNN probabilities whose pixel (x, y) prefers class (x + 3 y) % 14 with p 0.87 (0.01 elsewhere).
std::vector<float> cnn_probs(int w, int h) {
  std::vector<float> p(std::size_t(w) * std::size_t(h) * kLabelClasses, 0.01f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p[(std::size_t(y) * w + x) * kLabelClasses + std::size_t((x + 3 * y) % 14)] = 0.87f;
  return p;
}

void check_fuse(int W, int H, int Wc, int Hc, int scale) {
  FusionMap m = make_fusion_map(W, H, Wc, Hc, scale, 40);
  auto& [fusion, pool, index] = m;
  ASSERT_TRUE(fusion.ok());
  // Surfels 0..29 at scattered cells (each once); 30..39 invisible.
  std::vector<std::pair<int, int>> cell(30);
  for (int i = 0; i < 30; ++i) {
    const int k = (i * 11 + 1) % (W * scale * H * scale);  // 11 is coprime to every grid size used
    const int x = k % (W * scale), y = k / (W * scale);
    ASSERT_EQ(index.id(x, y), -1) << "test layout: cell used twice";
    index.id(x, y) = i;
    cell[std::size_t(i)] = {x, y};
  }
  const std::vector<float> probs = cnn_probs(Wc, Hc);
  const ProbabilityView view{probs.data(), Hc, Wc, kLabelClasses};
  auto counts = fusion->fuse(index, view, pool);
  ASSERT_TRUE(counts.ok()) << counts.error().message;
  EXPECT_EQ(counts->surfels_updated, 30);
  for (int i = 0; i < 40; ++i) {
    const uint8_t* s = pool.labels() + std::size_t(i) * 16;
    if (i >= 30) {
      for (int b = 0; b < 16; ++b) EXPECT_EQ(s[b], 0) << "invisible surfel " << i;
      continue;
    }
    const int u = cell[std::size_t(i)].first / scale, v = cell[std::size_t(i)].second / scale;
    const int cx = int(std::floor((u + 0.5) * Wc / W)), cy = int(std::floor((v + 0.5) * Hc / H));
    uint8_t want[16];
    observation_from_probabilities(view.pixel(cx, cy), want);  // uniform start: the observation itself
    want[14] = want[15] = 0;
    for (int b = 0; b < 16; ++b) EXPECT_EQ(s[b], want[b]) << "surfel " << i << " byte " << b;
    EXPECT_EQ(label_argmax(s), (cx + 3 * cy) % 14) << "surfel " << i;
  }
}

TEST(LabelFusion, UpdatesExactlyTheVisibleSurfelsIntegerRatio) { check_fuse(8, 6, 4, 3, 2); }
TEST(LabelFusion, UpdatesExactlyTheVisibleSurfelsNonIntegerRatio) { check_fuse(10, 7, 4, 3, 4); }
TEST(LabelFusion, UpdatesExactlyTheVisibleSurfelsScaleOne) { check_fuse(9, 8, 9, 8, 1); }

TEST(LabelFusion, RejectsMismatchedInputsAndLeavesThePool) {
  FusionMap m = make_fusion_map(4, 4, 2, 2, 1, 2);
  auto& [fusion, pool, index] = m;
  ASSERT_TRUE(fusion.ok());
  index.id(0, 0) = 0;
  index.id(3, 3) = 5;  // outside the pool
  const std::vector<float> probs = cnn_probs(2, 2);
  EXPECT_FALSE(fusion->fuse(index, {probs.data(), 2, 2, kLabelClasses}, pool).ok());
  for (int b = 0; b < 32; ++b) EXPECT_EQ(pool.labels()[b], 0);
  index.id(3, 3) = 1;
  EXPECT_FALSE(fusion->fuse(index, {probs.data(), 2, 3, kLabelClasses}, pool).ok());  // wrong CNN size
  index.scale = 2;
  EXPECT_FALSE(fusion->fuse(index, {probs.data(), 2, 2, kLabelClasses}, pool).ok());  // wrong index size
  index.scale = 1;
  EXPECT_TRUE(fusion->fuse(index, {probs.data(), 2, 2, kLabelClasses}, pool).ok());
}

TEST(LabelFusion, OptionsValidateAndSchedule) {
  LabelFusionOptions opt;
  EXPECT_TRUE(opt.validate().ok());
  opt.update_every_n_frames = 0;
  EXPECT_FALSE(LabelFusion::create(opt).ok());
  opt.update_every_n_frames = 10;
  auto f = LabelFusion::create(opt);
  ASSERT_TRUE(f.ok());
  EXPECT_TRUE(f->due(0));
  EXPECT_FALSE(f->due(9));
  EXPECT_TRUE(f->due(20));
}

TEST(LabelFusion, LabelsTravelWithSurfels) {
  slam::SurfelPool pool = make_pool(5);
  for (int i = 0; i < 5; ++i)
    for (int b = 0; b < 14; ++b) pool.labels()[std::size_t(i) * 16 + b] = static_cast<uint8_t>(10 * i + b);
  std::vector<uint8_t> last(pool.labels() + 4 * 16, pool.labels() + 5 * 16);
  pool.remove(1);  // surfel 4 moves into slot 1
  ASSERT_EQ(pool.size(), 4);
  EXPECT_EQ(0, std::memcmp(pool.labels() + 16, last.data(), 16));
  std::vector<uint8_t> s2(pool.labels() + 2 * 16, pool.labels() + 3 * 16);
  pool.copy_surfel(2, 0);
  EXPECT_EQ(0, std::memcmp(pool.labels(), s2.data(), 16));
  // A new surfel starts uniform (all zero).
  const int64_t id = pool.append(0, 0, 1, 0, 0, -1, 0.01f, 1, 0, 0);
  for (int b = 0; b < 16; ++b) EXPECT_EQ(pool.labels()[std::size_t(id) * 16 + b], 0);
}

// With the measured depth, only surfels at that depth take the CNN's label: one behind the surface
// (its centre in a cell the nearer surfels left free) and one on a pixel without depth do not.
TEST(LabelFusion, DepthTestSkipsHiddenSurfelsAndPixelsWithoutDepth) {
  FusionMap m = make_fusion_map(4, 2, 4, 2, 2, 3);
  auto& [fusion, pool, index] = m;
  ASSERT_TRUE(fusion.ok());
  index.depth.allocate(8, 4);
  index.id(0, 0) = 0;  // working pixel (0, 0): on the surface (2.00 m vs 2.02 measured)
  index.depth(0, 0) = 2.0f;
  index.id(1, 1) = 1;  // same pixel, 0.5 m behind: hidden
  index.depth(1, 1) = 2.5f;
  index.id(6, 2) = 2;  // working pixel (3, 1): no depth measured
  index.depth(6, 2) = 1.0f;
  Image<float> depth(4, 2);
  depth.fill(2.02f);
  depth(3, 1) = 0.0f;
  const std::vector<float> probs = cnn_probs(4, 2);
  const ProbabilityView view{probs.data(), 2, 4, kLabelClasses};
  auto r = fusion->fuse(index, view, pool, depth.view());
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->surfels_updated, 1);
  EXPECT_EQ(r->hidden_skipped, 1);
  EXPECT_EQ(r->no_depth_skipped, 1);
  // CNN pixel (0, 0) prefers class 0: surfel 0 now has class 0 at cost 0 and the others above it.
  EXPECT_EQ(pool.labels()[0], 0);
  EXPECT_GT(pool.labels()[1], 0);
  for (int b = 0; b < 16; ++b) {
    EXPECT_EQ(pool.labels()[16 + b], 0) << b;
    EXPECT_EQ(pool.labels()[32 + b], 0) << b;
  }
  // Without the depth image all three are updated.
  auto all = fusion->fuse(index, view, pool);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->surfels_updated, 3);
  // A depth image of the wrong size is refused.
  Image<float> wrong(3, 2);
  EXPECT_FALSE(fusion->fuse(index, view, pool, wrong.view()).ok());
}

TEST(LabelFusion, LabelsSurviveFlaggedRemovalInOrder) {
  slam::SurfelPool pool = make_pool(6);
  for (int i = 0; i < 6; ++i) pool.labels()[std::size_t(i) * 16 + 3] = static_cast<uint8_t>(40 + i);
  const uint8_t flags[6] = {0, 1, 0, 1, 1, 0};
  ASSERT_EQ(pool.remove_flagged(flags), 3);
  ASSERT_EQ(pool.size(), 3);
  const int kept[3] = {0, 2, 5};
  for (int i = 0; i < 3; ++i) EXPECT_EQ(pool.labels()[std::size_t(i) * 16 + 3], 40 + kept[i]) << i;
}

// Merging two surfels of one surface: the kept surfel's distribution becomes the normalised
// product of both (both are independent evidence), within the store's rounding.
TEST(LabelFusion, MergedSurfelsMultiplyTheirDistributions) {
  slam::SurfelPool pool = make_pool(2);
  float pa[kLabelClasses], pb[kLabelClasses];
  for (int c = 0; c < kLabelClasses; ++c) {
    pa[c] = 0.02f + 0.01f * float(c);
    pb[c] = 0.05f;
  }
  pa[3] = 0.5f;   // a: class 3, b: class 7 a bit more likely than 3
  pb[3] = 0.3f;
  pb[7] = 0.4f;
  encode_labels(pa, pool.labels());
  encode_labels(pb, pool.labels() + 16);
  uint8_t a_bytes[16], b_bytes[16];
  std::memcpy(a_bytes, pool.labels(), 16);
  std::memcpy(b_bytes, pool.labels() + 16, 16);
  slam::fusion_math::merge_into(pool, 0, 1);

  // Bytes: the closed form on costs.
  int m = 255;
  int t[kLabelClasses];
  for (int c = 0; c < kLabelClasses; ++c) {
    t[c] = std::min(255, int(a_bytes[c]) + int(b_bytes[c]));
    m = std::min(m, t[c]);
  }
  for (int c = 0; c < kLabelClasses; ++c) EXPECT_EQ(pool.labels()[c], t[c] - m) << c;
  EXPECT_EQ(pool.labels()[14], 0);
  EXPECT_EQ(pool.labels()[15], 0);
  // Probabilities: the product of the inputs, each encoding rounding by at most 1/32 nat.
  float got[kLabelClasses];
  decode_labels(pool.labels(), got);
  double z = 0;
  for (int c = 0; c < kLabelClasses; ++c) z += double(pa[c]) * double(pb[c]);
  for (int c = 0; c < kLabelClasses; ++c) {
    const double want = double(pa[c]) * double(pb[c]) / z;
    EXPECT_NEAR(std::log(double(got[c])), std::log(want), 4.0 / 32.0) << c;
  }
  EXPECT_EQ(label_argmax(pool.labels()), 3);  // 0.5 * 0.3 > 0.04 * 0.4
}

}  // namespace
}  // namespace ef::semantic
