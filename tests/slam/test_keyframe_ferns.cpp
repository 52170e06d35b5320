// The randomised-fern keyframe database (slam/keyframe_ferns.h): encodings, novelty, lookup order,
// the fixed capacity, restoring, and no allocation per frame.
#include <gtest/gtest.h>

#include <vector>

#include "core/image.h"
#include "slam/keyframe_ferns.h"
#include "support/alloc_counter.h"

namespace ef::slam {
namespace {

constexpr int kW = 160, kH = 120;

// A frame of a tilted plane and a colour gradient shifted by `shift` pixels (a camera pan).
struct TestFrame {
  Image<float> depth;
  Image<Rgb8> color;
  explicit TestFrame(int shift, float depth_offset = 0.0f) {
    depth.allocate(kW, kH);
    color.allocate(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const int u = x + shift;
        depth(x, y) = 1.0f + 0.02f * static_cast<float>((u * 7 + y * 3) % 150) + depth_offset;
        color(x, y) = Rgb8{static_cast<uint8_t>((u * 5) & 255), static_cast<uint8_t>((y * 2 + u) & 255),
                           static_cast<uint8_t>((u * y) & 255)};
      }
  }
};

KeyframeFerns make_ferns(KeyframeFernOptions o = {}) {
  auto f = KeyframeFerns::create(kW, kH, o);
  EXPECT_TRUE(f.ok()) << to_string(f.error());
  return std::move(*f);
}

TEST(KeyframeFerns, EncodingIsDeterministicAndSeparatesViews) {
  KeyframeFerns a = make_ferns(), b = make_ferns();
  FernCode ca = a.make_code(), cb = b.make_code(), other = a.make_code();
  const TestFrame f0(0), f80(80);
  a.encode(f0.depth.view(), f0.color.view(), &ca);
  b.encode(f0.depth.view(), f0.color.view(), &cb);
  EXPECT_EQ(ca.code, cb.code) << "the same seed gives the same ferns in every run";
  for (uint8_t c : ca.code) EXPECT_LT(c, 16);
  a.encode(f80.depth.view(), f80.color.view(), &other);
  ASSERT_GE(a.add_if_novel(ca, SE3(), 0), 0);
  EXPECT_EQ(a.nearest_dissimilarity(ca), 0.0f);
  EXPECT_GT(a.nearest_dissimilarity(other), 0.5f);
  // No colour: only the depth bit can be set.
  FernCode depth_only = a.make_code();
  a.encode(f0.depth.view(), ImageView<const Rgb8>(), &depth_only);
  for (uint8_t c : depth_only.code) EXPECT_EQ(c & 7, 0);
}

TEST(KeyframeFerns, OnlyNovelViewsBecomeKeyframesAndAFullDatabaseRefuses) {
  KeyframeFernOptions o;
  o.capacity = 2;
  KeyframeFerns db = make_ferns(o);
  FernCode c = db.make_code();
  const TestFrame f0(0), f1(1), f60(60), f120(120);
  db.encode(f0.depth.view(), f0.color.view(), &c);
  EXPECT_EQ(db.add_if_novel(c, SE3(), 0), 0);
  db.encode(f1.depth.view(), f1.color.view(), &c);  // one pixel on: not novel
  EXPECT_LT(db.nearest_dissimilarity(c), o.novelty_threshold);
  EXPECT_EQ(db.add_if_novel(c, SE3(), 1), -1);
  db.encode(f60.depth.view(), f60.color.view(), &c);
  EXPECT_EQ(db.add_if_novel(c, SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 2, 3)), 60), 1);
  EXPECT_EQ(db.frame(1), 60);
  EXPECT_EQ(db.pose(1).translation(), Eigen::Vector3d(1, 2, 3));
  db.encode(f120.depth.view(), f120.color.view(), &c);
  EXPECT_EQ(db.add_if_novel(c, SE3(), 120), -1);  // novel, but the database is full
  EXPECT_EQ(db.size(), 2);
  EXPECT_EQ(db.refused(), 1u);
}

TEST(KeyframeFerns, BestMatchesAreTheMostSimilarFirstWithinTheThreshold) {
  KeyframeFerns db = make_ferns();
  FernCode c = db.make_code();
  for (int shift : {0, 40, 80, 120}) {
    const TestFrame f(shift);
    db.encode(f.depth.view(), f.color.view(), &c);
    ASSERT_GE(db.add_if_novel(c, SE3(), shift), 0) << shift;
  }
  const TestFrame query(42);  // nearest to the keyframe at 40
  db.encode(query.depth.view(), query.color.view(), &c);
  KeyframeMatch m[3];
  const int n = db.best_matches(c, 1.0f, m, 3);
  ASSERT_EQ(n, 3);
  EXPECT_EQ(db.frame(m[0].keyframe), 40);
  EXPECT_LE(m[0].dissimilarity, m[1].dissimilarity);
  EXPECT_LE(m[1].dissimilarity, m[2].dissimilarity);
  // A tight threshold keeps only the close one; none at all when nothing qualifies.
  EXPECT_EQ(db.best_matches(c, m[0].dissimilarity, m, 3), 1);
  EXPECT_EQ(db.best_matches(c, m[0].dissimilarity - 0.01f, m, 3), 0);
}

TEST(KeyframeFerns, RestoreTakesASavedDatabaseAndRejectsWhatDoesNotFit) {
  KeyframeFerns a = make_ferns();
  FernCode c = a.make_code();
  for (int shift : {0, 70}) {
    const TestFrame f(shift);
    a.encode(f.depth.view(), f.color.view(), &c);
    a.add_if_novel(c, SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(shift, 0, 0)), shift);
  }
  KeyframeFerns b = make_ferns();
  ASSERT_TRUE(b.restore(a.size(), a.code(0), a.pose_words(), a.frames(), 3).ok());
  EXPECT_EQ(b.size(), 2);
  EXPECT_EQ(b.refused(), 3u);
  EXPECT_EQ(b.pose(1).translation().x(), 70.0);
  EXPECT_EQ(std::vector<uint8_t>(b.code(1), b.code(1) + b.ferns()), std::vector<uint8_t>(a.code(1), a.code(1) + a.ferns()));
  KeyframeFernOptions one;
  one.capacity = 1;
  KeyframeFerns small = make_ferns(one);
  EXPECT_FALSE(small.restore(2, a.code(0), a.pose_words(), a.frames(), 0).ok());
  std::vector<double> bad(a.pose_words(), a.pose_words() + 14);
  bad[6] = 3.0;  // quaternion w: not unit length
  const auto s = b.restore(2, a.code(0), bad.data(), a.frames(), 0);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("keyframe 0"), std::string::npos) << s.error().message;
}

TEST(KeyframeFerns, OptionsOutOfRangeAreRejected) {
  KeyframeFernOptions o;
  o.ferns = 0;
  EXPECT_FALSE(KeyframeFerns::create(kW, kH, o).ok());
  o = {};
  o.novelty_threshold = 1.5f;
  EXPECT_FALSE(KeyframeFerns::create(kW, kH, o).ok());
  o = {};
  o.depth_min_m = 5.0f;
  EXPECT_FALSE(KeyframeFerns::create(kW, kH, o).ok());
  EXPECT_FALSE(KeyframeFerns::create(0, kH).ok());
}

TEST(KeyframeFerns, EncodingAndLookupAllocateNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  KeyframeFerns db = make_ferns();
  FernCode c = db.make_code();
  const TestFrame f0(0), f50(50);
  KeyframeMatch m[4];
  test::AllocationCounter count;
  db.encode(f0.depth.view(), f0.color.view(), &c);
  db.add_if_novel(c, SE3(), 0);
  db.encode(f50.depth.view(), f50.color.view(), &c);
  db.add_if_novel(c, SE3(), 1);
  EXPECT_GE(db.best_matches(c, 1.0f, m, 4), 1);
  EXPECT_EQ(count.thread_allocations(), 0u);
}

}  // namespace
}  // namespace ef::slam
