#include "io/tum_source.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "io/image_codec.h"
#include "io/text_parse.h"
#include "kernels/depth_convert.h"

namespace ef {

namespace fs = std::filesystem;

namespace {

constexpr float kTumMetresPerUnit = 1.0f / 5000.0f;  // depth PNG units -> metres

Error line_error(const std::string& file, int line, const std::string& what) {
  return error(ErrorCode::kCorruptData, file + ", line " + std::to_string(line) + ": " + what);
}

std::string fmt_time(double t) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

}  // namespace

Result<std::vector<TimedPath>> parse_tum_list(std::string_view text, const std::string& file) {
  std::vector<TimedPath> out;
  std::vector<std::string_view> fields;
  Status s = text::for_each_data_line(text, [&](int line_no, std::string_view line) -> Status {
    text::split_fields(line, fields);
    if (fields.size() != 2)
      return line_error(file, line_no, "expected 'timestamp path', found " + std::to_string(fields.size()) +
                                           " fields in " + text::quote_excerpt(line));
    double t = 0;
    if (!text::parse_double(fields[0], t) || t < 0)
      return line_error(file, line_no, "timestamp " + text::quote_excerpt(fields[0]) + " is not a number of seconds");
    if (!out.empty() && !(t > out.back().timestamp))
      return line_error(file, line_no, "timestamp " + fmt_time(t) + " is not after the previous one (" +
                                           fmt_time(out.back().timestamp) + "): timestamps must increase");
    out.push_back(TimedPath{t, std::string(fields[1])});
    return Status();
  });
  if (!s.ok()) return s.take_error();
  return out;
}

Result<std::vector<StampedPose>> parse_tum_groundtruth(std::string_view text, const std::string& file) {
  std::vector<StampedPose> out;
  std::vector<std::string_view> fields;
  Status s = text::for_each_data_line(text, [&](int line_no, std::string_view line) -> Status {
    text::split_fields(line, fields);
    if (fields.size() != 8)
      return line_error(file, line_no, "expected 'timestamp tx ty tz qx qy qz qw', found " +
                                           std::to_string(fields.size()) + " fields in " + text::quote_excerpt(line));
    double v[8];
    for (int i = 0; i < 8; ++i) {
      if (!text::parse_double(fields[std::size_t(i)], v[i]))
        return line_error(file, line_no, "field " + std::to_string(i + 1) + " " +
                                             text::quote_excerpt(fields[std::size_t(i)]) + " is not a number");
    }
    if (!out.empty() && !(v[0] > out.back().timestamp))
      return line_error(file, line_no, "timestamp " + fmt_time(v[0]) + " is not after the previous one (" +
                                           fmt_time(out.back().timestamp) + "): timestamps must increase");
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // w, x, y, z
    const double norm = q.norm();
    if (!(norm > 0.5 && norm < 1.5))
      return line_error(file, line_no, "quaternion has norm " + std::to_string(norm) + ", not a rotation");
    out.push_back(StampedPose{v[0], SE3(q, Eigen::Vector3d(v[1], v[2], v[3]))});
    return Status();
  });
  if (!s.ok()) return s.take_error();
  return out;
}

Result<Intrinsics> parse_tum_intrinsics(std::string_view text, const std::string& file) {
  Intrinsics k;
  int lines = 0;
  std::vector<std::string_view> fields;
  Status s = text::for_each_data_line(text, [&](int line_no, std::string_view line) -> Status {
    if (++lines > 1) return line_error(file, line_no, "expected a single line 'fx fy cx cy'");
    text::split_fields(line, fields);
    if (fields.size() != 4)
      return line_error(file, line_no, "expected 'fx fy cx cy', found " + std::to_string(fields.size()) + " fields");
    double v[4];
    for (int i = 0; i < 4; ++i) {
      if (!text::parse_double(fields[std::size_t(i)], v[i]))
        return line_error(file, line_no, text::quote_excerpt(fields[std::size_t(i)]) + " is not a number");
    }
    if (v[0] == 0 || v[1] == 0) return line_error(file, line_no, "focal length of 0");
    k.fx = float(v[0]);
    k.fy = float(v[1]);
    k.cx = float(v[2]);
    k.cy = float(v[3]);
    return Status();
  });
  if (!s.ok()) return s.take_error();
  if (lines == 0) return error(ErrorCode::kCorruptData, file + ": no 'fx fy cx cy' line");
  return k;
}


bool lookup_pose(const std::vector<StampedPose>& gt, double t, double max_dt, SE3& out) {
  if (gt.empty()) return false;
  const auto it = std::lower_bound(gt.begin(), gt.end(), t,
                                   [](const StampedPose& p, double time) { return p.timestamp < time; });
  if (it != gt.end() && it->timestamp == t) {
    out = it->T_wc;
    return true;
  }
  const StampedPose* before = it != gt.begin() ? &*(it - 1) : nullptr;
  const StampedPose* after = it != gt.end() ? &*it : nullptr;
  const double dt_before = before ? t - before->timestamp : INFINITY;
  const double dt_after = after ? after->timestamp - t : INFINITY;
  if (std::min(dt_before, dt_after) > max_dt) return false;
  if (!before || !after) {
    out = before ? before->T_wc : after->T_wc;
    return true;
  }
  const double alpha = dt_before / (after->timestamp - before->timestamp);
  const Eigen::Quaterniond q = before->T_wc.rotation().slerp(alpha, after->T_wc.rotation());
  const Eigen::Vector3d p = (1 - alpha) * before->T_wc.translation() + alpha * after->T_wc.translation();
  out = SE3(q, p);
  return true;
}

namespace {

class TumSource final : public FrameSource {
 public:
  struct Entry {
    double timestamp;  // rgb timestamp, seconds
    std::string rgb, depth, labels;  // full paths
    std::string stem;
    bool has_pose;
    SE3 T_wc;
  };

  TumSource(SourceInfo info, std::string dir, std::vector<Entry> entries, Image<uint16_t> first_depth)
      : info_(std::move(info)), dir_(std::move(dir)), entries_(std::move(entries)), raw_(std::move(first_depth)) {}

  const SourceInfo& info() const override { return info_; }

  Result<int64_t> skip(int64_t n, Frame& /*scratch*/) override {
    const int64_t left = static_cast<int64_t>(entries_.size() - std::min(next_, entries_.size()));
    const int64_t skipped = std::min(std::max<int64_t>(n, 0), left);
    next_ += static_cast<std::size_t>(skipped);
    return skipped;
  }

  Result<bool> next(Frame& out) override {
    if (next_ >= entries_.size()) return false;
    const std::size_t idx = next_;
    const Entry& e = entries_[idx];
    const int w = info_.intrinsics.width, h = info_.intrinsics.height;
    const auto fail = [&](Error err) {
      return error(err.code, "TUM folder '" + dir_ + "', frame " + std::to_string(idx) + " (" + e.stem + "): " +
                                 err.message);
    };
    if (Status s = read_color_image(e.rgb, out.color); !s.ok()) return fail(s.take_error());
    if (out.color.width() != w || out.color.height() != h)
      return fail(error(ErrorCode::kCorruptData, "colour image '" + e.rgb + "' is " + size_text(out.color) +
                                                     ", expected " + size_text(w, h) + " like the depth images"));
    if (Status s = read_png_u16(e.depth, raw_); !s.ok()) return fail(s.take_error());
    if (raw_.width() != w || raw_.height() != h)
      return fail(error(ErrorCode::kCorruptData, "depth image '" + e.depth + "' is " + size_text(raw_) +
                                                     ", expected " + size_text(w, h)));
    out.depth.allocate(w, h);
    kernels::depth_u16_to_metres(raw_.data(), out.depth.data(), raw_.size(), kTumMetresPerUnit, 65535);
    if (info_.has_labels) {
      if (Status s = read_png_u8(e.labels, out.labels); !s.ok()) return fail(s.take_error());
      if (out.labels.width() != w || out.labels.height() != h)
        return fail(error(ErrorCode::kCorruptData, "label image '" + e.labels + "' is " + size_text(out.labels) +
                                                       ", expected " + size_text(w, h)));
    }
    out.has_labels = info_.has_labels;
    out.timestamp = e.timestamp;
    out.index = int64_t(idx);
    out.has_pose = e.has_pose;
    out.T_wc = e.has_pose ? e.T_wc : SE3();
    out.name.assign(e.stem, 0, Frame::kMaxFrameName);
    ++next_;
    return true;
  }

 private:
  template <class T>
  static std::string size_text(const Image<T>& im) {
    return size_text(im.width(), im.height());
  }
  static std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

  SourceInfo info_;
  std::string dir_;
  std::vector<Entry> entries_;
  Image<uint16_t> raw_;  // depth PNG samples, reused
  std::size_t next_ = 0;
};

}  // namespace

Result<std::unique_ptr<FrameSource>> open_tum(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"fx", "fy", "cx", "cy"}));
  const std::string& dir = uri.path;
  if (dir.empty()) return error(ErrorCode::kInvalidArgument, "tum: no folder given (expected tum:DIR)");
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return error(ErrorCode::kNotFound, "TUM folder '" + dir + "': " + (fs::exists(dir, ec) ? "not a folder" : "not found"));
  const fs::path root(dir);
  std::string text;

  const auto read_list = [&](const char* name) -> Result<std::vector<TimedPath>> {
    const std::string file = (root / name).string();
    if (Status s = text::read_text_file(file, text); !s.ok()) {
      Error e = s.take_error();
      return error(e.code, "TUM folder '" + dir + "': list " + e.message);
    }
    return parse_tum_list(text, "list '" + file + "'");
  };
  EF_ASSIGN_OR_RETURN(std::vector<TimedPath> rgb, read_list("rgb.txt"));
  EF_ASSIGN_OR_RETURN(std::vector<TimedPath> depth, read_list("depth.txt"));

  std::vector<double> rgb_t, depth_t;
  for (const auto& r : rgb) rgb_t.push_back(r.timestamp);
  for (const auto& d : depth) depth_t.push_back(d.timestamp);
  const auto pairs = associate_timestamps(rgb_t, depth_t, kTumMaxTimeDifference);
  if (pairs.empty())
    return error(ErrorCode::kCorruptData, "TUM folder '" + dir + "': no depth image within 0.02 s of any colour image (" +
                                              std::to_string(rgb.size()) + " in rgb.txt, " +
                                              std::to_string(depth.size()) + " in depth.txt)");

  std::vector<StampedPose> gt;
  const std::string gt_file = (root / "groundtruth.txt").string();
  const bool has_gt = fs::exists(gt_file, ec);
  if (has_gt) {
    EF_RETURN_IF_ERROR(text::read_text_file(gt_file, text));
    EF_ASSIGN_OR_RETURN(gt, parse_tum_groundtruth(text, "groundtruth '" + gt_file + "'"));
  }
  const fs::path labels_dir = root / "labels";
  const bool has_labels = fs::is_directory(labels_dir, ec);

  std::vector<TumSource::Entry> entries;
  entries.reserve(pairs.size());
  for (const auto& [ri, di] : pairs) {
    TumSource::Entry e;
    e.timestamp = rgb[ri].timestamp;
    e.rgb = (root / rgb[ri].path).string();
    e.depth = (root / depth[di].path).string();
    e.stem = fs::path(rgb[ri].path).stem().string();
    if (has_labels) {
      e.labels = (labels_dir / (e.stem + ".png")).string();
      if (!fs::exists(e.labels, ec))
        return error(ErrorCode::kNotFound, "TUM folder '" + dir + "', frame " + std::to_string(entries.size()) + " (" +
                                               e.stem + "): label image '" + e.labels +
                                               "' missing (labels/ must have one per frame)");
    }
    e.has_pose = has_gt && lookup_pose(gt, e.timestamp, kTumMaxTimeDifference, e.T_wc);
    entries.push_back(std::move(e));
  }

  // The image size comes from the first depth image.
  Image<uint16_t> first;
  if (Status s = read_png_u16(entries.front().depth, first); !s.ok()) {
    Error e = s.take_error();
    return error(e.code, "TUM folder '" + dir + "', frame 0 (" + entries.front().stem + "): " + e.message);
  }

  SourceInfo info;
  info.uri = "tum:" + dir;
  const std::string intr_file = (root / "intrinsics.txt").string();
  if (fs::exists(intr_file, ec)) {
    EF_RETURN_IF_ERROR(text::read_text_file(intr_file, text));
    EF_ASSIGN_OR_RETURN(info.intrinsics, parse_tum_intrinsics(text, "intrinsics '" + intr_file + "'"));
    info.intrinsics.width = first.width();
    info.intrinsics.height = first.height();
  } else {
    info.intrinsics = Intrinsics{525.0f, 525.0f, 319.5f, 239.5f, 640, 480};
    if (first.width() != 640 || first.height() != 480)
      info.intrinsics = info.intrinsics.scaled_to(first.width(), first.height());
  }
  EF_RETURN_IF_ERROR(text::apply_intrinsics_overrides(uri, info.intrinsics));
  const bool have_file = fs::exists(intr_file, ec);
  text::describe_intrinsics(uri, have_file ? intr_file : "the default of a Kinect v1 (fx 525, cx 319.5 at 640x480)",
                            !have_file, &info.intrinsics_from, &info.intrinsics_assumed);
  info.frame_count = int64_t(entries.size());
  if (entries.size() > 1) {
    const double span = entries.back().timestamp - entries.front().timestamp;
    if (span > 0) info.nominal_fps = double(entries.size() - 1) / span;
  }
  info.has_pose = has_gt;
  info.has_labels = has_labels;
  info.has_color = true;
  return std::unique_ptr<FrameSource>(new TumSource(std::move(info), dir, std::move(entries), std::move(first)));
}

}  // namespace ef
