// Label accuracy on tiny hand-made images whose confusion matrix is worked out by hand below.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "eval/label_eval.h"
#include "io/image_codec.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;

Image<uint8_t> make_u8(int w, int h, std::vector<uint8_t> px) {
  Image<uint8_t> im(w, h);
  for (int i = 0; i < w * h; ++i) im.data()[i] = px[i];
  return im;
}

// 4x2 images.
//   GT   1 1 1 1      EST  1 1 2 0
//        2 2 0 5           2 1 3 5
// Evaluated (gt != 0): 7 pixels. C[1][1]=2 C[1][2]=1 C[1][0]=1; C[2][2]=1 C[2][1]=1; C[5][5]=1.
// accuracy: bed 2/4, books 1/2, floor 1/1 -> class avg 2/3; pixel avg 4/7.
// IoU: bed 2/(4+3-2) = 2/5, books 1/(2+2-1) = 1/3, floor 1 -> mIoU 26/45.
Image<uint8_t> gt_a() { return make_u8(4, 2, {1, 1, 1, 1, 2, 2, 0, 5}); }
Image<uint8_t> est_a() { return make_u8(4, 2, {1, 1, 2, 0, 2, 1, 3, 5}); }

TEST(LabelEval, HandComputedConfusion) {
  ConfusionMatrix cm;
  ASSERT_TRUE(accumulate_confusion(gt_a().cview(), est_a().cview(), {}, cm, "a").ok());
  EXPECT_EQ(cm.total(), 7u);
  EXPECT_EQ(cm.counts[1][1], 2u);
  EXPECT_EQ(cm.counts[1][2], 1u);
  EXPECT_EQ(cm.counts[1][0], 1u);
  EXPECT_EQ(cm.counts[2][2], 1u);
  EXPECT_EQ(cm.counts[2][1], 1u);
  EXPECT_EQ(cm.counts[5][5], 1u);
  EXPECT_EQ(cm.counts[0][3], 0u);  // unknown ground truth is never counted
  const LabelMetrics m = compute_label_metrics(cm);
  EXPECT_EQ(m.pixels, 7u);
  EXPECT_EQ(m.classes_present, 3);
  EXPECT_DOUBLE_EQ(m.accuracy[kBed], 0.5);
  EXPECT_DOUBLE_EQ(m.accuracy[kBooks], 0.5);
  EXPECT_DOUBLE_EQ(m.accuracy[kFloor], 1.0);
  EXPECT_TRUE(std::isnan(m.accuracy[kCeiling]));
  EXPECT_NEAR(m.class_average, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(m.pixel_average, 4.0 / 7.0, 1e-12);
  EXPECT_NEAR(m.iou[kBed], 0.4, 1e-12);
  EXPECT_NEAR(m.iou[kBooks], 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(m.iou[kFloor], 1.0, 1e-12);
  EXPECT_NEAR(m.miou, 26.0 / 45.0, 1e-12);
}

// Depth 0 at (3,0) [gt bed, est unknown] and (1,1) [gt books, est bed]:
// bed 2/3, books 1/1, floor 1 -> class avg 8/9, pixel avg 4/5; IoU bed 2/(3+2-2) = 2/3,
// books 1/(1+2-1) = 1/2, floor 1 -> mIoU 13/18.
Image<uint16_t> depth_a() {
  Image<uint16_t> d(4, 2);
  d.fill(5000);
  d(3, 0) = 0;
  d(1, 1) = 0;
  return d;
}

TEST(LabelEval, DepthMaskExcludesPixels) {
  ConfusionMatrix cm;
  const Image<uint16_t> d = depth_a();
  ASSERT_TRUE(accumulate_confusion(gt_a().cview(), est_a().cview(), d.cview(), cm, "a").ok());
  const LabelMetrics m = compute_label_metrics(cm);
  EXPECT_EQ(m.pixels, 5u);
  EXPECT_NEAR(m.class_average, 8.0 / 9.0, 1e-12);
  EXPECT_NEAR(m.pixel_average, 0.8, 1e-12);
  EXPECT_NEAR(m.miou, 13.0 / 18.0, 1e-12);
}

TEST(LabelEval, RejectsBadIdsAndSizes) {
  ConfusionMatrix cm;
  auto bad = make_u8(4, 2, {1, 1, 2, 0, 2, 14, 3, 5});
  Status s = accumulate_confusion(gt_a().cview(), bad.cview(), {}, cm, "x.png");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("x.png: class id 14 at (1, 1) in the estimate"), std::string::npos)
      << s.error().message;
  EXPECT_EQ(cm.total(), 0u);  // nothing half-counted
  auto small = make_u8(2, 2, {1, 1, 1, 1});
  s = accumulate_confusion(gt_a().cview(), small.cview(), {}, cm, "y.png");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("size mismatch, ground truth 4x2 vs estimate 2x2"), std::string::npos);
}

struct Dirs {
  fs::path root, gt, est, depth;
};
Dirs make_dirs(const std::string& name) {
  Dirs d;
  d.root = test::scratch_dir(name);
  d.gt = d.root / "gt";
  d.est = d.root / "est";
  d.depth = d.root / "depth";
  fs::create_directories(d.gt);
  fs::create_directories(d.est);
  fs::create_directories(d.depth);
  return d;
}

void put(const fs::path& p, const Image<uint8_t>& im) { ASSERT_TRUE(write_png(p.string(), im.cview()).ok()) << p; }

TEST(LabelEval, FoldersWithDepthMatchHandComputation) {
  const Dirs d = make_dirs("label_dirs");
  put(d.gt / "0001.png", gt_a());
  put(d.est / "0001.png", est_a());
  put(d.est / "9999.png", est_a());  // estimate without ground truth: ignored
  ASSERT_TRUE(write_png((d.depth / "0001.png").string(), depth_a().cview()).ok());
  auto r = evaluate_labels(d.gt.string(), d.est.string());
  ASSERT_TRUE(r.ok()) << to_string(r.error());
  EXPECT_EQ(r->images, 1);
  EXPECT_NEAR(r->metrics.class_average, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(r->metrics.miou, 26.0 / 45.0, 1e-12);
  LabelEvalOptions opt;
  opt.depth_dir = d.depth.string();
  auto rd = evaluate_labels(d.gt.string(), d.est.string(), opt);
  ASSERT_TRUE(rd.ok()) << to_string(rd.error());
  EXPECT_NEAR(rd->metrics.class_average, 8.0 / 9.0, 1e-12);
  EXPECT_NEAR(rd->metrics.pixel_average, 0.8, 1e-12);
  const std::string text = format_label_report(*rd);
  EXPECT_NE(text.find("class_avg 0.888889\n"), std::string::npos) << text;
  EXPECT_NE(text.find("pixel_avg 0.800000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("miou 0.722222\n"), std::string::npos) << text;
  EXPECT_NE(text.find("acc_bed 0.666667\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("acc_ceiling"), std::string::npos) << text;  // absent classes get no line
}

// Three 2x1 frames: a and c predicted perfectly, b all wrong. --every 2 keeps a and c.
TEST(LabelEval, EveryKthFileInNameOrder) {
  const Dirs d = make_dirs("label_every");
  const Image<uint8_t> g = make_u8(2, 1, {12, 5});
  const Image<uint8_t> wrong = make_u8(2, 1, {5, 12});
  for (const char* n : {"a.png", "b.png", "c.png"}) put(d.gt / n, g);
  put(d.est / "a.png", g);
  put(d.est / "b.png", wrong);
  put(d.est / "c.png", g);
  auto all = evaluate_labels(d.gt.string(), d.est.string());
  ASSERT_TRUE(all.ok()) << to_string(all.error());
  EXPECT_EQ(all->images, 3);
  EXPECT_NEAR(all->metrics.pixel_average, 4.0 / 6.0, 1e-12);
  LabelEvalOptions opt;
  opt.every = 2;
  auto some = evaluate_labels(d.gt.string(), d.est.string(), opt);
  ASSERT_TRUE(some.ok()) << to_string(some.error());
  EXPECT_EQ(some->images, 2);
  EXPECT_DOUBLE_EQ(some->metrics.pixel_average, 1.0);
  opt.every = 0;
  EXPECT_FALSE(evaluate_labels(d.gt.string(), d.est.string(), opt).ok());
}

TEST(LabelEval, MissingEstimateIsAnErrorWithCount) {
  const Dirs d = make_dirs("label_missing");
  const Image<uint8_t> g = make_u8(2, 1, {1, 2});
  for (const char* n : {"a.png", "b.png", "c.png"}) put(d.gt / n, g);
  put(d.est / "b.png", g);
  auto r = evaluate_labels(d.gt.string(), d.est.string());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
  EXPECT_NE(r.error().message.find("2 estimate file(s) missing in " + d.est.string() + " (a.png, c.png) of 3"),
            std::string::npos)
      << r.error().message;
  LabelEvalOptions opt;
  opt.depth_dir = d.depth.string();
  put(d.est / "a.png", g);
  put(d.est / "c.png", g);
  auto rd = evaluate_labels(d.gt.string(), d.est.string(), opt);
  ASSERT_FALSE(rd.ok());
  EXPECT_NE(rd.error().message.find("3 depth file(s) missing"), std::string::npos) << rd.error().message;
}

TEST(LabelEval, SizeMismatchAndWrongDepthOfPngNameFiles) {
  const Dirs d = make_dirs("label_bad");
  put(d.gt / "a.png", make_u8(2, 1, {1, 2}));
  put(d.est / "a.png", make_u8(1, 1, {1}));
  auto r = evaluate_labels(d.gt.string(), d.est.string());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find((d.gt / "a.png").string()), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find((d.est / "a.png").string()), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("size mismatch"), std::string::npos) << r.error().message;

  // A 16-bit PNG where an 8-bit class-id image is expected.
  Image<uint16_t> wide(2, 1);
  ASSERT_TRUE(write_png((d.est / "a.png").string(), wide.cview()).ok());
  auto r16 = evaluate_labels(d.gt.string(), d.est.string());
  ASSERT_FALSE(r16.ok());
  EXPECT_NE(r16.error().message.find((d.est / "a.png").string()), std::string::npos) << r16.error().message;

  auto empty = evaluate_labels(d.depth.string(), d.est.string());
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.error().message.find("no .png label images"), std::string::npos);
  EXPECT_FALSE(evaluate_labels((d.root / "nope").string(), d.est.string()).ok());
}

}  // namespace
}  // namespace ef
