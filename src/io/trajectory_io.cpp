#include "io/trajectory_io.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include <fcntl.h>
#include <unistd.h>

#include "io/durable_file.h"

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

namespace {

// One line of a TUM file: a comment (a "# lost" one marks the next pose), a blank, or a pose appended
// to `traj`. Errors name the file and the line.
Status parse_line(const std::string& line, const std::string& path, int line_no, Trajectory& traj,
                  bool& next_lost) {
  static const char* const kFieldNames[8] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  const std::size_t first = line.find_first_not_of(" \t\r");
  if (first == std::string::npos) return Status::success();
  if (line[first] == '#') {
    next_lost = next_lost || line.compare(first, 7, "# lost ") == 0;
    return Status::success();
  }
  std::string fields[8];
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
  // Components past ~1e154 overflow the norm: normalised, such a quaternion is NaN or zero, a pose
  // that is no rotation (found by fuzz_trajectory, issue 34).
  if (!std::isfinite(qn))
    return error(ErrorCode::kCorruptData, where(path, line_no) + "quaternion too large to normalise (its norm overflows)");
  if (!traj.poses.empty() && v[0] == traj.poses.back().timestamp) {
    // The same instant twice: the later line wins (the TUM tools' dictionary keeps the last).
    if (traj.duplicates++ == 0) traj.first_duplicate_line = line_no;
    traj.poses.back() = TimedPose{v[0], SE3(q, Eigen::Vector3d(v[1], v[2], v[3])), next_lost};
    next_lost = false;
    return Status::success();
  }
  if (!traj.poses.empty() && !(v[0] > traj.poses.back().timestamp)) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "timestamp %.6f is before the previous one (%.6f)", v[0],
                  traj.poses.back().timestamp);
    return error(ErrorCode::kCorruptData, where(path, line_no) + buf);
  }
  traj.poses.push_back(TimedPose{v[0], SE3(q, Eigen::Vector3d(v[1], v[2], v[3])), next_lost});
  next_lost = false;
  return Status::success();
}

}  // namespace

std::string Trajectory::cut_line_warning() const {
  if (cut_line == 0) return {};
  return source + ":" + std::to_string(cut_line) +
         ": the last line was cut while the file was written (no newline, not a whole pose); left out";
}

std::string Trajectory::duplicate_warning() const {
  if (duplicates == 0) return {};
  return source + ":" + std::to_string(first_duplicate_line) + ": " + std::to_string(duplicates) +
         (duplicates == 1 ? " pose line repeats" : " pose lines repeat") +
         " the previous line's timestamp; the later pose kept (as the TUM tools do)";
}

Result<Trajectory> read_tum_trajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) return error(ErrorCode::kNotFound, path + ": cannot open trajectory file");
  Trajectory traj;
  traj.source = path;
  std::string line;
  int line_no = 0;
  bool next_lost = false;  // a "# lost" line was read and no pose line since
  while (std::getline(in, line)) {
    ++line_no;
    // eof while reading a line that was returned: the file ends without a newline.
    if (in.eof()) {
      if (!parse_line(line, path, line_no, traj, next_lost).ok()) traj.cut_line = line_no;
      break;
    }
    EF_RETURN_IF_ERROR(parse_line(line, path, line_no, traj, next_lost));
  }
  if (in.bad()) return error(ErrorCode::kIoError, path + ": read failed after line " + std::to_string(line_no));
  return traj;
}

TumTrajectoryWriter::~TumTrajectoryWriter() { (void)close(); }

namespace {
int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

Status TumTrajectoryWriter::open(const std::string& path, double sync_seconds) {
  (void)close();
  path_ = path;
  sync_seconds_ = sync_seconds;
  bytes_ = 0;
  lines_ = 0;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) return error(ErrorCode::kIoError, path + ": cannot create trajectory file: " + std::strerror(errno));
  last_sync_ns_ = steady_ns();
  static constexpr char kHeader[] = "# timestamp tx ty tz qx qy qz qw\n";
  return append(kHeader, sizeof kHeader - 1);
}

Status TumTrajectoryWriter::open_append(const std::string& path, int64_t keep_bytes, double sync_seconds) {
  (void)close();
  path_ = path;
  sync_seconds_ = sync_seconds;
  lines_ = 0;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd_ < 0) return error(ErrorCode::kIoError, path + ": cannot continue the trajectory: " + std::strerror(errno));
  const off_t size = ::lseek(fd_, 0, SEEK_END);
  if (size < keep_bytes) {
    (void)close();
    return error(ErrorCode::kCorruptData, path + ": has " + std::to_string(size) + " bytes, fewer than the " +
                                              std::to_string(keep_bytes) + " the checkpoint covers");
  }
  if (::ftruncate(fd_, static_cast<off_t>(keep_bytes)) != 0 || ::lseek(fd_, static_cast<off_t>(keep_bytes), SEEK_SET) < 0) {
    const int e = errno;
    (void)close();
    return error(ErrorCode::kIoError, path + ": cannot cut it back to the checkpoint: " + std::strerror(e));
  }
  bytes_ = keep_bytes;
  last_sync_ns_ = steady_ns();
  unsynced_ = true;  // the cut is synced with the next line
  return Status::success();
}

Status TumTrajectoryWriter::append(const char* line, std::size_t n) {
  std::size_t done = 0;
  while (done < n) {
    const ssize_t w = ::write(fd_, line + done, n - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const int e = w < 0 ? errno : ENOSPC;
      // A part of the line went out: cut the file back to the last whole line.
      if (done > 0 && ::ftruncate(fd_, static_cast<off_t>(bytes_)) == 0) ::lseek(fd_, static_cast<off_t>(bytes_), SEEK_SET);
      return error(ErrorCode::kIoError, path_ + ": write failed after " + std::to_string(lines_) +
                                            " lines: " + std::strerror(e));
    }
    done += static_cast<std::size_t>(w);
  }
  bytes_ += static_cast<int64_t>(n);
  ++lines_;
  unsynced_ = true;
  if (sync_seconds_ >= 0) {
    const int64_t now = steady_ns();
    if (static_cast<double>(now - last_sync_ns_) >= sync_seconds_ * 1e9) return flush();
  }
  return Status::success();
}

namespace {
// One pose line with its newline into `line` (256 bytes); returns its length, or 0 when it does not fit.
// The timestamp is given as text: written with 6 decimals (the writer), or as a file had it (rewrite).
int format_pose_line(char* line, const char* timestamp, const SE3& T_wc) {
  Eigen::Quaterniond q = T_wc.rotation();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d& t = T_wc.translation();
  const int n = std::snprintf(line, 256, "%s %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", timestamp, t.x(), t.y(), t.z(),
                              q.x(), q.y(), q.z(), q.w());
  return n > 0 && n < 256 ? n : 0;
}
int format_pose_line(char* line, double timestamp, const SE3& T_wc) {
  char stamp[400];
  const int n = std::snprintf(stamp, sizeof stamp, "%.6f", timestamp);
  return n > 0 && n < static_cast<int>(sizeof stamp) ? format_pose_line(line, stamp, T_wc) : 0;
}
int format_pose_line(char* line, const std::string& timestamp, const SE3& T_wc) {
  return timestamp.size() < 200 ? format_pose_line(line, timestamp.c_str(), T_wc) : 0;
}
}  // namespace

Status TumTrajectoryWriter::write(double timestamp, const SE3& T_wc) {
  if (fd_ < 0) return error(ErrorCode::kInvalidArgument, "trajectory writer: write() before open()");
  char line[256];
  const int n = format_pose_line(line, timestamp, T_wc);
  if (n == 0) return error(ErrorCode::kInvalidArgument, path_ + ": pose line too long");
  return append(line, static_cast<std::size_t>(n));
}

Status TumTrajectoryWriter::write_comment(const char* text) {
  if (fd_ < 0) return error(ErrorCode::kInvalidArgument, "trajectory writer: write_comment() before open()");
  char line[256];
  const int n = std::snprintf(line, sizeof line, "# %s\n", text);
  if (n <= 0 || n >= static_cast<int>(sizeof line) || std::strchr(text, '\n') != nullptr)
    return error(ErrorCode::kInvalidArgument, path_ + ": a comment must be one line of at most 250 bytes");
  return append(line, static_cast<std::size_t>(n));
}

Status TumTrajectoryWriter::flush() {
  if (fd_ < 0 || !unsynced_) return Status::success();
  last_sync_ns_ = steady_ns();
  if (::fdatasync(fd_) != 0) return error(ErrorCode::kIoError, path_ + ": sync failed: " + std::strerror(errno));
  unsynced_ = false;
  return Status::success();
}

Status TumTrajectoryWriter::close() {
  if (fd_ < 0) return Status::success();
  Status synced = flush();
  if (::close(fd_) != 0 && synced.ok()) synced = error(ErrorCode::kIoError, path_ + ": close failed: " + std::strerror(errno));
  fd_ = -1;
  return synced;
}

namespace detail {

Result<TumRewrite> rewrite_tum_poses(const std::string& path, PoseCorrector correct, void* context,
                                     const std::string& comment, std::size_t comment_key) {
  if (comment.find('\n') != std::string::npos)
    return error(ErrorCode::kInvalidArgument, path + ": a comment must be one line");
  std::ifstream in(path, std::ios::binary);
  if (!in) return error(ErrorCode::kNotFound, path + ": cannot open trajectory file to rewrite it");
  std::string text, line;
  TumRewrite counts;
  Trajectory parsed;  // parse_line's: the last pose only (timestamps must still increase)
  parsed.source = path;
  bool next_lost = false;
  int line_no = 0;
  char pose_line[256];
  while (std::getline(in, line)) {
    ++line_no;
    if (in.eof())  // a last line without its newline: not one of ours
      return error(ErrorCode::kCorruptData, where(path, line_no) + "the last line has no newline; not rewritten");
    const bool earlier_comment = comment_key > 0 && line.size() >= 2 + comment_key &&
                                 line.compare(0, 2, "# ") == 0 && line.compare(2, comment_key, comment, 0, comment_key) == 0;
    if (earlier_comment) continue;
    const std::size_t poses_before = parsed.poses.size();
    const int duplicates_before = parsed.duplicates;
    EF_RETURN_IF_ERROR(parse_line(line, path, line_no, parsed, next_lost));
    // A pose line: a new pose, or one repeating the previous line's timestamp (which replaced it).
    if (parsed.poses.size() > poses_before || parsed.duplicates > duplicates_before) {
      TimedPose& p = parsed.poses.back();
      SE3 T = p.T_wc;
      int n = 0;
      if (correct(context, p.timestamp, &T)) {
        // The timestamp as written (its first field), never reformatted: rounded to microseconds it
        // could fall before an earlier line's and leave a file no reader takes (found by
        // fuzz_trajectory, issue 34); as written, eval associates by the same instants as before.
        std::string fields[1];
        split_fields(line, fields, 1);
        n = format_pose_line(pose_line, fields[0], T);
      }
      if (n > 0) {
        text.append(pose_line, static_cast<std::size_t>(n));
        ++counts.corrected;
      } else {
        text += line;
        text += '\n';
        ++counts.kept;
      }
      parsed.poses.erase(parsed.poses.begin(), parsed.poses.end() - 1);
    } else {
      text += line;
      text += '\n';
    }
    if (line_no == 1 && !comment.empty()) text += "# " + comment + "\n";
  }
  if (in.bad()) return error(ErrorCode::kIoError, path + ": read failed after line " + std::to_string(line_no));
  EF_RETURN_IF_ERROR(write_file_whole(path, {{text.data(), text.size()}}));
  counts.bytes = static_cast<int64_t>(text.size());
  return counts;
}

}  // namespace detail

Status write_tum_trajectory(const std::string& path, const std::vector<TimedPose>& poses) {
  TumTrajectoryWriter w;
  EF_RETURN_IF_ERROR(w.open(path));
  for (const TimedPose& p : poses) EF_RETURN_IF_ERROR(w.write(p.timestamp, p.T_wc));
  return w.close();
}

}  // namespace ef
