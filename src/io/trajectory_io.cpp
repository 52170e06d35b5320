#include "io/trajectory_io.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace ef {

namespace {

std::string where(const std::string& path, int line) { return path + ":" + std::to_string(line) + ": "; }

// Splits `line` on blanks into at most `max_fields` tokens; returns the token count (which may
// exceed max_fields: counting continues, storing stops).
int split_fields(const std::string& line, std::string* fields, int max_fields) {
  int n = 0;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == ',')) ++i;
    if (i >= line.size()) break;
    std::size_t j = i;
    while (j < line.size() && !(line[j] == ' ' || line[j] == '\t' || line[j] == '\r' || line[j] == ',')) ++j;
    if (n < max_fields) fields[n] = line.substr(i, j - i);
    ++n;
    i = j;
  }
  return n;
}

bool parse_double(const std::string& s, double& out) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && errno != ERANGE && std::isfinite(out);
}

}  // namespace

Result<Trajectory> read_tum_trajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) return error(ErrorCode::kNotFound, path + ": cannot open trajectory file");
  static const char* const kFieldNames[8] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  Trajectory traj;
  traj.source = path;
  std::string line;
  std::string fields[8];
  int line_no = 0;
  bool next_lost = false;  // a "# lost" line was read and no pose line since
  while (std::getline(in, line)) {
    ++line_no;
    std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) continue;
    if (line[first] == '#') {
      next_lost = next_lost || line.compare(first, 7, "# lost ") == 0;
      continue;
    }
    const int n = split_fields(line, fields, 8);
    if (n != 8) {
      return error(ErrorCode::kCorruptData, where(path, line_no) + "expected 8 fields "
                   "'timestamp tx ty tz qx qy qz qw', found " + std::to_string(n));
    }
    double v[8];
    for (int k = 0; k < 8; ++k) {
      if (!parse_double(fields[k], v[k])) {
        return error(ErrorCode::kCorruptData, where(path, line_no) + "field " + std::to_string(k + 1) + " (" +
                     kFieldNames[k] + ") '" + fields[k] + "' is not a finite number");
      }
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // (w, x, y, z)
    const double qn = q.norm();
    if (!(qn > 1e-9)) return error(ErrorCode::kCorruptData, where(path, line_no) + "zero quaternion");
    if (!traj.poses.empty() && !(v[0] > traj.poses.back().timestamp)) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "timestamp %.6f is not after the previous one (%.6f)", v[0],
                    traj.poses.back().timestamp);
      return error(ErrorCode::kCorruptData, where(path, line_no) + buf);
    }
    traj.poses.push_back(TimedPose{v[0], SE3(q, Eigen::Vector3d(v[1], v[2], v[3])), next_lost});
    next_lost = false;
  }
  if (in.bad()) return error(ErrorCode::kIoError, path + ": read failed after line " + std::to_string(line_no));
  return traj;
}

TumTrajectoryWriter::~TumTrajectoryWriter() {
  if (file_) std::fclose(file_);
}

Status TumTrajectoryWriter::open(const std::string& path) {
  if (file_) {
    std::fclose(file_);
    file_ = nullptr;
  }
  path_ = path;
  file_ = std::fopen(path.c_str(), "w");
  if (!file_) return error(ErrorCode::kIoError, path + ": cannot create trajectory file: " + std::strerror(errno));
  if (std::fputs("# timestamp tx ty tz qx qy qz qw\n", file_) < 0)
    return error(ErrorCode::kIoError, path + ": write failed");
  return Status::success();
}

Status TumTrajectoryWriter::write(double timestamp, const SE3& T_wc) {
  if (!file_) return error(ErrorCode::kInvalidArgument, "trajectory writer: write() before open()");
  Eigen::Quaterniond q = T_wc.rotation();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d& t = T_wc.translation();
  const int rc = std::fprintf(file_, "%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", timestamp, t.x(), t.y(), t.z(),
                              q.x(), q.y(), q.z(), q.w());
  if (rc < 0) return error(ErrorCode::kIoError, path_ + ": write failed");
  return Status::success();
}

Status TumTrajectoryWriter::write_comment(const char* text) {
  if (!file_) return error(ErrorCode::kInvalidArgument, "trajectory writer: write_comment() before open()");
  if (std::fprintf(file_, "# %s\n", text) < 0) return error(ErrorCode::kIoError, path_ + ": write failed");
  return Status::success();
}

Status TumTrajectoryWriter::flush() {
  if (!file_) return Status::success();
  if (std::fflush(file_) != 0) return error(ErrorCode::kIoError, path_ + ": flush failed: " + std::strerror(errno));
  return Status::success();
}

Status TumTrajectoryWriter::close() {
  if (!file_) return Status::success();
  const bool write_failed = std::ferror(file_) != 0;
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (write_failed || rc != 0) return error(ErrorCode::kIoError, path_ + ": write or close failed");
  return Status::success();
}

Status write_tum_trajectory(const std::string& path, const std::vector<TimedPose>& poses) {
  TumTrajectoryWriter w;
  EF_RETURN_IF_ERROR(w.open(path));
  for (const TimedPose& p : poses) EF_RETURN_IF_ERROR(w.write(p.timestamp, p.T_wc));
  return w.close();
}

}  // namespace ef
