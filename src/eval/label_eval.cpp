#include "eval/label_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <vector>

#include "io/image_codec.h"

namespace ef {

namespace fs = std::filesystem;

uint64_t ConfusionMatrix::total() const {
  uint64_t n = 0;
  for (const auto& row : counts)
    for (uint64_t c : row) n += c;
  return n;
}

Status accumulate_confusion(ImageView<const uint8_t> gt, ImageView<const uint8_t> est, ImageView<const uint16_t> depth,
                            ConfusionMatrix& cm, const std::string& what) {
  if (gt.width != est.width || gt.height != est.height) {
    return error(ErrorCode::kInvalidArgument, what + ": size mismatch, ground truth " + std::to_string(gt.width) + "x" +
                 std::to_string(gt.height) + " vs estimate " + std::to_string(est.width) + "x" +
                 std::to_string(est.height));
  }
  const bool use_depth = !depth.empty();
  if (use_depth && (depth.width != gt.width || depth.height != gt.height)) {
    return error(ErrorCode::kInvalidArgument, what + ": size mismatch, depth " + std::to_string(depth.width) + "x" +
                 std::to_string(depth.height) + " vs labels " + std::to_string(gt.width) + "x" +
                 std::to_string(gt.height));
  }
  // Validate first so that a bad image leaves the matrix untouched.
  for (int y = 0; y < gt.height; ++y) {
    const uint8_t* g = gt.row(y);
    const uint8_t* e = est.row(y);
    for (int x = 0; x < gt.width; ++x) {
      if (g[x] >= kNumClassesWithUnknown || e[x] >= kNumClassesWithUnknown) {
        const bool in_gt = g[x] >= kNumClassesWithUnknown;
        return error(ErrorCode::kCorruptData, what + ": class id " + std::to_string(in_gt ? g[x] : e[x]) + " at (" +
                     std::to_string(x) + ", " + std::to_string(y) + ") in the " + (in_gt ? "ground truth" : "estimate") +
                     " is above 13");
      }
    }
  }
  for (int y = 0; y < gt.height; ++y) {
    const uint8_t* g = gt.row(y);
    const uint8_t* e = est.row(y);
    const uint16_t* d = use_depth ? depth.row(y) : nullptr;
    for (int x = 0; x < gt.width; ++x) {
      if (g[x] == kUnknown) continue;
      if (d && d[x] == 0) continue;
      ++cm.counts[g[x]][e[x]];
    }
  }
  return Status::success();
}

LabelMetrics compute_label_metrics(const ConfusionMatrix& cm) {
  LabelMetrics m;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::array<uint64_t, kNumClassesWithUnknown> col{};
  uint64_t correct = 0;
  for (int g = 1; g < kNumClassesWithUnknown; ++g) {
    for (int e = 0; e < kNumClassesWithUnknown; ++e) {
      m.gt_pixels[g] += cm.counts[g][e];
      col[e] += cm.counts[g][e];
    }
    correct += cm.counts[g][g];
  }
  m.accuracy[0] = m.iou[0] = nan;
  double acc_sum = 0, iou_sum = 0;
  for (int c = 1; c < kNumClassesWithUnknown; ++c) {
    m.pixels += m.gt_pixels[c];
    if (m.gt_pixels[c] == 0) {
      m.accuracy[c] = m.iou[c] = nan;
      continue;
    }
    const double tp = static_cast<double>(cm.counts[c][c]);
    m.accuracy[c] = tp / static_cast<double>(m.gt_pixels[c]);
    m.iou[c] = tp / static_cast<double>(m.gt_pixels[c] + col[c] - cm.counts[c][c]);
    acc_sum += m.accuracy[c];
    iou_sum += m.iou[c];
    ++m.classes_present;
  }
  if (m.classes_present > 0) {
    m.class_average = acc_sum / m.classes_present;
    m.miou = iou_sum / m.classes_present;
  }
  if (m.pixels > 0) m.pixel_average = static_cast<double>(correct) / static_cast<double>(m.pixels);
  return m;
}

namespace {

Result<std::vector<std::string>> list_pngs(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return error(ErrorCode::kNotFound, dir + ": not a folder");
  std::vector<std::string> names;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const fs::path& p = it->path();
    if (p.extension() == ".png" || p.extension() == ".PNG") names.push_back(p.filename().string());
  }
  if (ec) return error(ErrorCode::kIoError, dir + ": cannot list folder: " + ec.message());
  std::sort(names.begin(), names.end());
  return names;
}

std::string describe_missing(const std::vector<std::string>& missing, const std::string& dir, const char* kind) {
  std::string msg = std::to_string(missing.size()) + " " + kind + " file(s) missing in " + dir + " (";
  for (std::size_t i = 0; i < missing.size() && i < 5; ++i) msg += (i ? ", " : "") + missing[i];
  if (missing.size() > 5) msg += ", ...";
  return msg + ")";
}

}  // namespace

Result<LabelEvalResult> evaluate_labels(const std::string& gt_dir, const std::string& est_dir,
                                        const LabelEvalOptions& options) {
  if (options.every < 1) return error(ErrorCode::kInvalidArgument, "label eval: --every must be >= 1");
  EF_ASSIGN_OR_RETURN(std::vector<std::string> all, list_pngs(gt_dir));
  {
    std::error_code ec;
    if (!fs::is_directory(est_dir, ec)) return error(ErrorCode::kNotFound, est_dir + ": not a folder");
    if (!options.depth_dir.empty() && !fs::is_directory(options.depth_dir, ec))
      return error(ErrorCode::kNotFound, options.depth_dir + ": not a folder");
  }
  if (all.empty()) return error(ErrorCode::kNotFound, gt_dir + ": no .png label images");
  std::vector<std::string> names;
  for (std::size_t i = 0; i < all.size(); i += static_cast<std::size_t>(options.every)) names.push_back(all[i]);

  std::vector<std::string> missing_est, missing_depth;
  for (const std::string& n : names) {
    std::error_code ec;
    if (!fs::exists(fs::path(est_dir) / n, ec)) missing_est.push_back(n);
    if (!options.depth_dir.empty() && !fs::exists(fs::path(options.depth_dir) / n, ec)) missing_depth.push_back(n);
  }
  if (!missing_est.empty()) {
    return error(ErrorCode::kNotFound, "label eval: " + describe_missing(missing_est, est_dir, "estimate") + " of " +
                 std::to_string(names.size()) + " ground-truth files in " + gt_dir);
  }
  if (!missing_depth.empty()) {
    return error(ErrorCode::kNotFound, "label eval: " + describe_missing(missing_depth, options.depth_dir, "depth") +
                 " of " + std::to_string(names.size()) + " ground-truth files in " + gt_dir);
  }

  LabelEvalResult r;
  Image<uint8_t> gt, est;
  Image<uint16_t> depth;
  for (const std::string& n : names) {
    const std::string gt_path = (fs::path(gt_dir) / n).string();
    const std::string est_path = (fs::path(est_dir) / n).string();
    EF_RETURN_IF_ERROR(read_png_u8(gt_path, gt));
    EF_RETURN_IF_ERROR(read_png_u8(est_path, est));
    std::string what = gt_path + " vs " + est_path;
    ImageView<const uint16_t> dview;
    if (!options.depth_dir.empty()) {
      const std::string depth_path = (fs::path(options.depth_dir) / n).string();
      EF_RETURN_IF_ERROR(read_png_u16(depth_path, depth));
      dview = depth.cview();
      what += " (depth " + depth_path + ")";
    }
    EF_RETURN_IF_ERROR(accumulate_confusion(gt.cview(), est.cview(), dview, r.confusion, what));
    ++r.images;
  }
  r.metrics = compute_label_metrics(r.confusion);
  return r;
}

std::string format_label_report(const LabelEvalResult& r) {
  const LabelMetrics& m = r.metrics;
  std::string out;
  char line[160];
  std::snprintf(line, sizeof line, "%-10s %12s %9s %9s\n", "class", "gt_pixels", "acc_%", "iou_%");
  out += line;
  for (int c = 1; c < kNumClassesWithUnknown; ++c) {
    const std::string name(class_name(c));
    if (m.gt_pixels[c] == 0) {
      std::snprintf(line, sizeof line, "%-10s %12llu %9s %9s\n", name.c_str(), 0ULL, "-", "-");
    } else {
      std::snprintf(line, sizeof line, "%-10s %12llu %9.2f %9.2f\n", name.c_str(),
                    static_cast<unsigned long long>(m.gt_pixels[c]), 100.0 * m.accuracy[c], 100.0 * m.iou[c]);
    }
    out += line;
  }
  std::snprintf(line, sizeof line, "%-10s %12llu %9.2f %9.2f  (over %d classes present)\n", "average",
                static_cast<unsigned long long>(m.pixels), 100.0 * m.class_average, 100.0 * m.miou,
                m.classes_present);
  out += line;
  std::snprintf(line, sizeof line, "%-10s %12s %9.2f\n", "pixel avg", "", 100.0 * m.pixel_average);
  out += line;
  std::snprintf(line, sizeof line, "class_avg %.6f\npixel_avg %.6f\nmiou %.6f\npixels %llu\nimages %d\n",
                m.class_average, m.pixel_average, m.miou, static_cast<unsigned long long>(m.pixels), r.images);
  out += line;
  for (int c = 1; c < kNumClassesWithUnknown; ++c) {
    if (m.gt_pixels[c] == 0) continue;
    const std::string name(class_name(c));
    std::snprintf(line, sizeof line, "acc_%s %.6f\niou_%s %.6f\n", name.c_str(), m.accuracy[c], name.c_str(),
                  m.iou[c]);
    out += line;
  }
  return out;
}

}  // namespace ef
