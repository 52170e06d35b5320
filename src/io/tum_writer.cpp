#include "io/tum_writer.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <unistd.h>

#include "io/image_codec.h"

namespace ef {

namespace fs = std::filesystem;

namespace {
constexpr double kUnitsPerMetre = 5000.0;  // TUM depth PNG scale
}

TumWriter::~TumWriter() {
  if (open_) (void)close();
}

Status TumWriter::write_line(std::FILE*& f, const char* name, const std::string& line) {
  if (!f) {
    const std::string path = (fs::path(dir_) / name).string();
    f = std::fopen(path.c_str(), "wb");
    if (!f) return error(ErrorCode::kIoError, "TUM folder '" + dir_ + "': cannot create '" + path + "' (" +
                                                  std::strerror(errno) + ")");
    if (std::strcmp(name, "groundtruth.txt") == 0)
      std::fputs("# ground truth trajectory (camera to world)\n# timestamp tx ty tz qx qy qz qw\n", f);
    else
      std::fprintf(f, "# %s images\n# timestamp filename\n", std::strcmp(name, "rgb.txt") == 0 ? "color" : "depth");
  }
  // Each line reaches the file with its frame (flushed), whole: a line that did not fit (a full disk)
  // is cut off again, so a converted folder killed at any moment lists whole frames only.
  const off_t before = ftello(f);
  if (std::fputs(line.c_str(), f) < 0 || std::fflush(f) != 0) {
    const int e = errno;
    std::clearerr(f);
    if (before >= 0 && ::ftruncate(fileno(f), before) == 0) fseeko(f, before, SEEK_SET);
    return error(ErrorCode::kIoError, "TUM folder '" + dir_ + "': cannot write " + name + ": " + std::strerror(e));
  }
  return Status();
}

Status TumWriter::open(const std::string& dir, const Intrinsics& intrinsics) {
  if (open_) return error(ErrorCode::kInvalidArgument, "TUM writer: already open on '" + dir_ + "'");
  if (dir.empty()) return error(ErrorCode::kInvalidArgument, "TUM writer: empty folder name");
  dir_ = dir;
  std::error_code ec;
  fs::create_directories(fs::path(dir) / "rgb", ec);
  if (!ec) fs::create_directories(fs::path(dir) / "depth", ec);
  if (ec) return error(ErrorCode::kIoError, "TUM folder '" + dir + "': cannot create (" + ec.message() + ")");
  frames_ = 0;
  stems_.clear();
  labels_dir_made_ = false;
  open_ = true;
  EF_RETURN_IF_ERROR(write_line(rgb_txt_, "rgb.txt", ""));
  EF_RETURN_IF_ERROR(write_line(depth_txt_, "depth.txt", ""));
  if (intrinsics.valid()) {
    const std::string path = (fs::path(dir) / "intrinsics.txt").string();
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return error(ErrorCode::kIoError, "TUM folder '" + dir + "': cannot create '" + path + "'");
    std::fprintf(f, "# fx fy cx cy (pixels, for %dx%d images)\n%.9g %.9g %.9g %.9g\n", intrinsics.width,
                 intrinsics.height, double(intrinsics.fx), double(intrinsics.fy), double(intrinsics.cx),
                 double(intrinsics.cy));
    if (std::fclose(f) != 0) return error(ErrorCode::kIoError, "TUM folder '" + dir + "': cannot write '" + path + "'");
  }
  return Status();
}

Status TumWriter::write(const Frame& frame) {
  if (!open_) return error(ErrorCode::kInvalidArgument, "TUM writer: write() before open()");
  const auto bad = [&](const std::string& what) {
    return error(ErrorCode::kInvalidArgument, "TUM folder '" + dir_ + "', frame " + std::to_string(frames_) + ": " + what);
  };
  if (frame.depth.empty()) return bad("no depth image");
  const int w = frame.depth.width(), h = frame.depth.height();
  if (!frame.color.empty() && (frame.color.width() != w || frame.color.height() != h))
    return bad("colour and depth sizes differ");
  if (frame.has_labels && (frame.labels.width() != w || frame.labels.height() != h))
    return bad("label and depth sizes differ");
  char ts[64];
  std::snprintf(ts, sizeof(ts), "%.6f", frame.timestamp);
  const double t = std::strtod(ts, nullptr);
  if (!std::isfinite(frame.timestamp) || frame.timestamp < 0) return bad("timestamp not a non-negative number");
  if (frames_ > 0 && !(t > last_timestamp_))
    return bad(std::string("timestamp ") + ts + " is not after the previous frame's (TUM lists need increasing times)");
  const std::string stem = frame.name.empty() ? std::string(ts) : frame.name;
  if (stem.find('/') != std::string::npos || stem.find('\\') != std::string::npos || stem[0] == '.')
    return bad("frame name '" + stem + "' cannot be a file stem");
  if (!stems_.insert(stem).second) return bad("frame name '" + stem + "' used twice");

  const std::string rgb_rel = "rgb/" + stem + ".png", depth_rel = "depth/" + stem + ".png";
  if (frame.color.empty()) {
    black_.allocate(w, h);
    black_.fill(Rgb8{0, 0, 0});
  }
  EF_RETURN_IF_ERROR(write_png((fs::path(dir_) / rgb_rel).string(), frame.color.empty() ? black_.cview() : frame.color.cview()));
  depth_units_.allocate(w, h);
  const float* d = frame.depth.data();
  uint16_t* u = depth_units_.data();
  for (std::size_t i = 0; i < depth_units_.size(); ++i) {
    const double v = std::isfinite(d[i]) && d[i] > 0 ? std::round(double(d[i]) * kUnitsPerMetre) : 0.0;
    u[i] = v <= 65535.0 ? uint16_t(v) : 0;
  }
  EF_RETURN_IF_ERROR(write_png((fs::path(dir_) / depth_rel).string(), depth_units_.cview()));
  if (frame.has_labels) {
    if (!labels_dir_made_) {
      std::error_code ec;
      fs::create_directories(fs::path(dir_) / "labels", ec);
      if (ec) return error(ErrorCode::kIoError, "TUM folder '" + dir_ + "': cannot create labels/ (" + ec.message() + ")");
      labels_dir_made_ = true;
    }
    EF_RETURN_IF_ERROR(write_png((fs::path(dir_) / "labels" / (stem + ".png")).string(), frame.labels.cview()));
  }
  EF_RETURN_IF_ERROR(write_line(rgb_txt_, "rgb.txt", std::string(ts) + " " + rgb_rel + "\n"));
  EF_RETURN_IF_ERROR(write_line(depth_txt_, "depth.txt", std::string(ts) + " " + depth_rel + "\n"));
  if (frame.has_pose) {
    const Eigen::Vector3d& p = frame.T_wc.translation();
    const Eigen::Quaterniond& q = frame.T_wc.rotation();
    char line[512];
    std::snprintf(line, sizeof(line), "%s %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", ts, p.x(), p.y(), p.z(), q.x(),
                  q.y(), q.z(), q.w());
    EF_RETURN_IF_ERROR(write_line(gt_txt_, "groundtruth.txt", line));
  }
  last_timestamp_ = t;
  ++frames_;
  return Status();
}

Status TumWriter::close() {
  if (!open_) return Status();
  open_ = false;
  bool ok = true;
  int e = 0;
  for (std::FILE** f : {&rgb_txt_, &depth_txt_, &gt_txt_}) {
    if (*f) {
      if (std::fflush(*f) != 0 || ::fsync(fileno(*f)) != 0) e = errno;
      if (std::fclose(*f) != 0 && e == 0) e = errno;
      ok = ok && e == 0;
    }
    *f = nullptr;
  }
  if (!ok)
    return error(ErrorCode::kIoError, "TUM folder '" + dir_ + "': cannot finish the list files: " + std::strerror(e));
  return Status();
}

}  // namespace ef
