// Semantic label accuracy as in SemanticFusion's NYUv2 evaluation: class-id images (0 = unknown,
// 1..13 the NYUv2 13 classes, core/classes.h) compared pixel by pixel. Pixels whose ground truth is
// unknown (0) are excluded, and so are pixels without depth (0) when a depth image is given.
// An estimate of 0 (unknown) on an evaluated pixel counts as wrong.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "core/classes.h"
#include "core/image.h"
#include "core/result.h"

namespace ef {

// counts[gt][est], ids 0..13. Row 0 stays zero (unknown ground truth is never counted).
struct ConfusionMatrix {
  std::array<std::array<uint64_t, kNumClassesWithUnknown>, kNumClassesWithUnknown> counts{};
  uint64_t total() const;
};

struct LabelMetrics {
  // Indexed by class id; entry 0 unused. NaN where the class is absent from the ground truth.
  std::array<double, kNumClassesWithUnknown> accuracy{};  // recall: C[c][c] / sum_e C[c][e]
  std::array<double, kNumClassesWithUnknown> iou{};       // C[c][c] / (row_c + col_c - C[c][c])
  std::array<uint64_t, kNumClassesWithUnknown> gt_pixels{};
  int classes_present = 0;   // classes 1..13 with at least one ground-truth pixel
  double class_average = 0;  // mean accuracy over present classes (0 when none)
  double pixel_average = 0;  // correct / evaluated pixels (0 when none)
  double miou = 0;           // mean IoU over present classes (0 when none)
  uint64_t pixels = 0;       // evaluated pixels
};

// Adds one image pair. `depth` may be empty (no depth mask); otherwise pixels with depth 0 are
// skipped. Errors: size mismatch, class ids above 13 in either image. `what` names the files.
Status accumulate_confusion(ImageView<const uint8_t> gt, ImageView<const uint8_t> est, ImageView<const uint16_t> depth,
                            ConfusionMatrix& cm, const std::string& what);

LabelMetrics compute_label_metrics(const ConfusionMatrix& cm);

struct LabelEvalOptions {
  std::string depth_dir;  // empty: no depth mask; else "<stem>.png" 16-bit depth per ground-truth file
  int every = 1;          // use only every K-th ground-truth file (sorted name order, starting with the first)
};

struct LabelEvalResult {
  ConfusionMatrix confusion;
  LabelMetrics metrics;
  int images = 0;  // image pairs evaluated
};

// Ground-truth files are the *.png in gt_dir (not recursive), sorted by name, thinned by `every`;
// each is matched with the file of the same name in est_dir. Strict: a ground-truth file without an
// estimate (or without a depth file when depth_dir is set) is an error that reports how many are
// missing and names the first few; estimate files without ground truth are ignored. Other errors
// name the file: not an 8-bit single-channel PNG, size mismatch, class id > 13, empty gt_dir.
Result<LabelEvalResult> evaluate_labels(const std::string& gt_dir, const std::string& est_dir,
                                        const LabelEvalOptions& options = {});

// A readable aligned table (class, ground-truth pixels, accuracy %, IoU %) followed by
// machine-readable lines: "class_avg 0.xxxxxx", "pixel_avg ...", "miou ...", "pixels N", "images N",
// and "acc_<class> ..." / "iou_<class> ..." for present classes.
std::string format_label_report(const LabelEvalResult& r);

}  // namespace ef
