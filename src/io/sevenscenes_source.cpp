#include "io/sevenscenes_source.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "io/image_codec.h"
#include "io/text_parse.h"
#include "kernels/depth_convert.h"

namespace ef {

namespace fs = std::filesystem;

namespace {

constexpr float kMetresPerMillimetre = 0.001f;
constexpr uint16_t kMaxValidMillimetres = 65534;  // 65535 marks "no depth" in 7-Scenes
constexpr double kFrameRate = 30.0;               // Hz
constexpr int64_t kMaxFrames = 10000000;

// Collects the numbers of a small matrix file with the line of each; errors name file and line.
Status read_numbers(std::string_view text, const std::string& file, std::size_t max_count, std::vector<double>& out) {
  out.clear();
  std::vector<std::string_view> fields;
  return text::for_each_data_line(text, [&](int line_no, std::string_view line) -> Status {
    text::split_fields(line, fields);
    for (std::string_view f : fields) {
      double v = 0;
      if (!text::parse_double(f, v))
        return error(ErrorCode::kCorruptData,
                     file + ", line " + std::to_string(line_no) + ": " + text::quote_excerpt(f) + " is not a number");
      if (out.size() == max_count)
        return error(ErrorCode::kCorruptData, file + ", line " + std::to_string(line_no) + ": more than " +
                                                  std::to_string(max_count) + " numbers");
      out.push_back(v);
    }
    return Status();
  });
}

}  // namespace

Result<SE3> parse_7scenes_pose(std::string_view text, const std::string& file) {
  std::vector<double> v;
  EF_RETURN_IF_ERROR(read_numbers(text, file, 16, v));
  if (v.size() != 16)
    return error(ErrorCode::kCorruptData, file + ": expected a 4x4 matrix (16 numbers), found " +
                                              std::to_string(v.size()) + " numbers");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[std::size_t(r * 4 + c)];
  if (std::abs(m(3, 0)) > 1e-6 || std::abs(m(3, 1)) > 1e-6 || std::abs(m(3, 2)) > 1e-6 || std::abs(m(3, 3) - 1) > 1e-6)
    return error(ErrorCode::kCorruptData, file + ": last row of the pose is not 0 0 0 1");
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  const double ortho = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(ortho < 1e-3) || !(R.determinant() > 0))
    return error(ErrorCode::kCorruptData, file + ": the 3x3 block of the pose is not a rotation (|R^T R - I| = " +
                                              std::to_string(ortho) + ", det = " + std::to_string(R.determinant()) + ")");
  return SE3(m);
}

Result<Intrinsics> parse_7scenes_intrinsics(std::string_view text, const std::string& file) {
  std::vector<double> v;
  EF_RETURN_IF_ERROR(read_numbers(text, file, 9, v));
  if (v.size() != 9)
    return error(ErrorCode::kCorruptData, file + ": expected a 3x3 camera matrix (9 numbers), found " +
                                              std::to_string(v.size()) + " numbers");
  if (v[0] == 0 || v[4] == 0 || v[1] != 0 || v[3] != 0 || v[6] != 0 || v[7] != 0 || v[8] != 1)
    return error(ErrorCode::kCorruptData, file + ": not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  Intrinsics k;
  k.fx = float(v[0]);
  k.fy = float(v[4]);
  k.cx = float(v[2]);
  k.cy = float(v[5]);
  return k;
}

namespace {

class SevenScenesSource final : public FrameSource {
 public:
  struct Entry {
    std::string color, depth, pose;  // full paths; pose empty when the sequence has none
    std::string stem;                // "frame-000042"
  };

  SevenScenesSource(SourceInfo info, std::string dir, std::vector<Entry> entries)
      : info_(std::move(info)), dir_(std::move(dir)), entries_(std::move(entries)) {
    raw_.allocate(info_.intrinsics.width, info_.intrinsics.height);
    text_.reserve(1024);
  }

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
      return error(err.code, "7-Scenes folder '" + dir_ + "', frame " + std::to_string(idx) + ": " + err.message);
    };
    const auto size_of = [](int iw, int ih) { return std::to_string(iw) + "x" + std::to_string(ih); };
    if (Status s = read_color_image(e.color, out.color); !s.ok()) return fail(s.take_error());
    if (Status s = read_png_u16(e.depth, raw_); !s.ok()) return fail(s.take_error());
    if (raw_.width() != w || raw_.height() != h)
      return fail(error(ErrorCode::kCorruptData, "depth image '" + e.depth + "' is " + size_of(raw_.width(), raw_.height()) +
                                                     ", expected " + size_of(w, h) + " like frame 0"));
    if (out.color.width() != w || out.color.height() != h)
      return fail(error(ErrorCode::kCorruptData, "colour image '" + e.color + "' is " +
                                                     size_of(out.color.width(), out.color.height()) +
                                                     ", but the depth image is " + size_of(w, h)));
    out.depth.allocate(w, h);
    kernels::depth_u16_to_metres(raw_.data(), out.depth.data(), raw_.size(), kMetresPerMillimetre, kMaxValidMillimetres);
    out.has_pose = false;
    if (info_.has_pose) {
      if (Status s = text::read_text_file(e.pose, text_); !s.ok()) return fail(s.take_error());
      Result<SE3> pose = parse_7scenes_pose(text_, "pose file '" + e.pose + "'");
      if (!pose.ok()) return fail(pose.take_error());
      out.T_wc = *pose;
      out.has_pose = true;
    }
    out.has_labels = false;
    out.timestamp = double(idx) / kFrameRate;
    out.index = int64_t(idx);
    out.name.assign(e.stem, 0, Frame::kMaxFrameName);
    ++next_;
    return true;
  }

 private:
  SourceInfo info_;
  std::string dir_;
  std::vector<Entry> entries_;
  Image<uint16_t> raw_;  // millimetres, reused
  std::string text_;     // pose file text, reused
  std::size_t next_ = 0;
};

// "frame-000042.depth.png" -> index 42 and suffix ".depth.png"; false for other names.
bool parse_frame_name(const std::string& name, int64_t& index, std::string& suffix) {
  if (name.compare(0, 6, "frame-") != 0) return false;
  std::size_t i = 6;
  while (i < name.size() && name[i] >= '0' && name[i] <= '9') ++i;
  if (i == 6 || i - 6 > 7) return false;
  if (!text::parse_int(std::string_view(name).substr(6, i - 6), 0, kMaxFrames - 1, index)) return false;
  suffix = name.substr(i);
  return true;
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_7scenes(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"fx", "fy", "cx", "cy"}));
  const std::string& dir = uri.path;
  if (dir.empty()) return error(ErrorCode::kInvalidArgument, "7scenes: no folder given (expected 7scenes:DIR)");
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return error(ErrorCode::kNotFound,
                 "7-Scenes folder '" + dir + "': " + (fs::exists(dir, ec) ? "not a folder" : "not found"));
  const fs::path root(dir);

  // Which files exist, per frame index: bit 0 colour jpg, 1 colour png, 2 depth, 3 pose.
  std::vector<uint8_t> have;
  int64_t max_index = -1;
  bool any_pose = false;
  for (fs::directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    int64_t index = 0;
    std::string suffix;
    if (!parse_frame_name(it->path().filename().string(), index, suffix)) continue;
    int bit = -1;
    if (suffix == ".color.jpg") bit = 0;
    else if (suffix == ".color.png") bit = 1;
    else if (suffix == ".depth.png") bit = 2;
    else if (suffix == ".pose.txt") bit = 3;
    if (bit < 0) continue;
    if (index >= int64_t(have.size())) have.resize(std::size_t(index) + 1, 0);
    have[std::size_t(index)] |= uint8_t(1u << bit);
    max_index = std::max(max_index, index);
    any_pose = any_pose || bit == 3;
  }
  if (ec) return error(ErrorCode::kIoError, "7-Scenes folder '" + dir + "': cannot list (" + ec.message() + ")");
  if (max_index < 0)
    return error(ErrorCode::kNotFound, "7-Scenes folder '" + dir + "': no frame-NNNNNN.depth.png / .color.jpg files");

  std::vector<SevenScenesSource::Entry> entries(std::size_t(max_index) + 1);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06lld", static_cast<long long>(i));
    auto& e = entries[i];
    e.stem = stem;
    const auto missing = [&](const std::string& file) {
      return error(ErrorCode::kNotFound, "7-Scenes folder '" + dir + "', frame " + std::to_string(i) + ": '" + file +
                                             "' missing (frames must be numbered from 0 without gaps)");
    };
    e.color = (root / (e.stem + ((have[i] & 2) && !(have[i] & 1) ? ".color.png" : ".color.jpg"))).string();
    e.depth = (root / (e.stem + ".depth.png")).string();
    if (!(have[i] & 3)) return missing(e.color);
    if (!(have[i] & 4)) return missing(e.depth);
    if (any_pose) {
      e.pose = (root / (e.stem + ".pose.txt")).string();
      if (!(have[i] & 8)) return missing(e.pose);
    }
  }

  // The image size comes from frame 0's depth.
  Image<uint16_t> first;
  if (Status s = read_png_u16(entries[0].depth, first); !s.ok()) {
    Error e = s.take_error();
    return error(e.code, "7-Scenes folder '" + dir + "', frame 0: " + e.message);
  }
  SourceInfo info;
  info.uri = "7scenes:" + dir;
  const std::string intr_file = (root / "camera-intrinsics.txt").string();
  if (fs::exists(intr_file, ec)) {
    std::string text;
    EF_RETURN_IF_ERROR(text::read_text_file(intr_file, text));
    EF_ASSIGN_OR_RETURN(info.intrinsics, parse_7scenes_intrinsics(text, "intrinsics file '" + intr_file + "'"));
  } else {
    info.intrinsics = Intrinsics{585.0f, 585.0f, 320.0f, 240.0f, 0, 0};
  }
  info.intrinsics.width = first.width();
  info.intrinsics.height = first.height();
  EF_RETURN_IF_ERROR(text::apply_intrinsics_overrides(uri, info.intrinsics));
  const bool have_file = fs::exists(intr_file, ec);
  text::describe_intrinsics(uri, have_file ? intr_file : "7-Scenes' published ones (fx 585, cx 320 at 640x480)",
                            false, &info.intrinsics_from, &info.intrinsics_assumed);
  info.frame_count = int64_t(entries.size());
  info.nominal_fps = kFrameRate;
  info.has_pose = any_pose;
  info.has_labels = false;
  info.has_color = true;
  return std::unique_ptr<FrameSource>(new SevenScenesSource(std::move(info), dir, std::move(entries)));
}

}  // namespace ef
