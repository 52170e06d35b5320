// TUM RGB-D trajectory files: one pose per line, "timestamp tx ty tz qx qy qz qw", camera-to-world
// (T_wc), timestamp in seconds, translation in metres, unit quaternion (Hamilton, w last).
// Lines starting with '#' and blank lines are ignored, except that a line starting "# lost " (what
// `edgefusion run` writes before the pose of a frame whose tracking was lost) marks the pose line
// that follows it as lost.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "core/result.h"
#include "core/se3.h"

namespace ef {

struct TimedPose {
  double timestamp = 0;  // seconds
  SE3 T_wc;              // camera to world; metres
  bool lost = false;     // after a "# lost" line: tracking was lost, T_wc is the last good pose
};

struct Trajectory {
  std::string source;            // file it came from (or a label such as "ground truth"); used in errors
  std::vector<TimedPose> poses;  // strictly increasing timestamps
};

// Reads a TUM trajectory. Errors name the file and the 1-based line: a field that is not a finite
// number, a line without exactly 8 fields, a zero quaternion, a timestamp not strictly greater than
// the previous one. An empty file (no poses) is not an error here; evaluators reject it.
Result<Trajectory> read_tum_trajectory(const std::string& path);

// Writes poses one per frame to a TUM file: open once, then write() per frame without allocating.
// Timestamps are written with 6 decimals (microseconds), translations and quaternions with 9
// significant digits. The quaternion is written with qw >= 0.
class TumTrajectoryWriter {
 public:
  TumTrajectoryWriter() = default;
  ~TumTrajectoryWriter();
  TumTrajectoryWriter(const TumTrajectoryWriter&) = delete;
  TumTrajectoryWriter& operator=(const TumTrajectoryWriter&) = delete;

  // Creates (truncates) `path` and writes a '#' header line. The parent folder must exist.
  Status open(const std::string& path);
  // Appends one line. Error if not open or the write fails.
  Status write(double timestamp, const SE3& T_wc);
  // Appends "# <text>" as its own line (TUM readers skip it). `text` must be one line. Used by
  // `edgefusion run` to mark a lost frame just before its pose line: "# lost <timestamp> <reason>".
  Status write_comment(const char* text);
  // Flushes the stdio buffer to the OS (the file stays open).
  Status flush();
  // Flushes and closes; reports a failed final write. Safe to call twice.
  Status close();
  bool is_open() const { return file_ != nullptr; }
  const std::string& path() const { return path_; }

 private:
  std::FILE* file_ = nullptr;
  std::string path_;
};

// Convenience: writes a whole trajectory.
Status write_tum_trajectory(const std::string& path, const std::vector<TimedPose>& poses);

}  // namespace ef
