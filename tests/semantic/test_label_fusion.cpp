// LabelFusion::fuse on a small hand-built pool and index map: exactly the visible surfels are
// updated, each with the CNN pixel the nearest-neighbour rule gives; labels travel with surfels
// when the pool copies or removes them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "semantic/label_fusion.h"
#include "semantic/label_store.h"
#include "slam/index_map.h"
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

// CNN probabilities whose pixel (x, y) prefers class (x + 3 y) % 14 with p 0.87 (0.01 elsewhere).
std::vector<float> cnn_probs(int w, int h) {
  std::vector<float> p(std::size_t(w) * std::size_t(h) * kLabelClasses, 0.01f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p[(std::size_t(y) * w + x) * kLabelClasses + std::size_t((x + 3 * y) % 14)] = 0.87f;
  return p;
}

void check_fuse(int W, int H, int Wc, int Hc, int scale) {
  LabelFusionOptions opt;
  opt.working_width = W;
  opt.working_height = H;
  opt.cnn_width = Wc;
  opt.cnn_height = Hc;
  auto fusion = LabelFusion::create(opt);
  ASSERT_TRUE(fusion.ok());
  slam::SurfelPool pool = make_pool(40);
  slam::IndexMap index;
  index.scale = scale;
  index.id.allocate(W * scale, H * scale);
  index.id.fill(-1);
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
  LabelFusionOptions opt;
  opt.working_width = 4;
  opt.working_height = 4;
  opt.cnn_width = 2;
  opt.cnn_height = 2;
  auto fusion = LabelFusion::create(opt);
  ASSERT_TRUE(fusion.ok());
  slam::SurfelPool pool = make_pool(2);
  slam::IndexMap index;
  index.scale = 1;
  index.id.allocate(4, 4);
  index.id.fill(-1);
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

}  // namespace
}  // namespace ef::semantic
