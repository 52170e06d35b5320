// TUM RGB-D trajectory files: one pose per line, "timestamp tx ty tz qx qy qz qw", camera-to-world
// (T_wc), timestamp in seconds, translation in metres, unit quaternion (Hamilton, w last).
// Lines starting with '#' and blank lines are ignored, except that a line starting "# lost " (what
// `edgefusion run` writes before the pose of a frame whose tracking was lost) marks the pose line
// that follows it as lost.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <type_traits>
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
  // The 1-based number of a last line that was cut while the file was written (no newline, not a
  // valid pose line); it was left out. 0: none. Readers say so (cut_line_warning()).
  int cut_line = 0;
  std::string cut_line_warning() const;  // empty when cut_line == 0
  // Pose lines whose timestamp equalled the previous one's (TUM fr2/desk's ground truth has one): the
  // later line replaced the earlier, as the TUM benchmark's tools keep the last. first_duplicate_line:
  // the 1-based line of the first. Readers say so (duplicate_warning()).
  int duplicates = 0;
  int first_duplicate_line = 0;
  std::string duplicate_warning() const;  // empty when duplicates == 0
};

// Reads a TUM trajectory. Errors name the file and the 1-based line: a field that is not a finite
// number, a line without exactly 8 fields, a zero quaternion or one whose norm overflows, a timestamp smaller than the previous
// one (an equal one replaces the previous pose: Trajectory::duplicates). An empty file (no poses) is not an error here; evaluators reject it. A last line
// without its newline that is not a valid pose line is what a writer killed mid-line leaves: it is
// left out and named in Trajectory::cut_line, not an error (one with its newline is an error).
Result<Trajectory> read_tum_trajectory(const std::string& path);

// Writes poses one per frame to a TUM file: open once, then write() per frame without allocating.
// Timestamps are written with 6 decimals (microseconds), translations and quaternions with 9
// significant digits. The quaternion is written with qw >= 0.
//
// Crash safety (issue 29): each line goes to the file in one write(2), so a killed process leaves
// whole lines only; a write that fails part way (a full disk) is cut back to the last whole line and
// reported. The file is synced (fdatasync) at most `sync_seconds` after a line was written (0: after
// every line; negative: only at close), so a power cut loses at most that long.
class TumTrajectoryWriter {
 public:
  TumTrajectoryWriter() = default;
  ~TumTrajectoryWriter();
  TumTrajectoryWriter(const TumTrajectoryWriter&) = delete;
  TumTrajectoryWriter& operator=(const TumTrajectoryWriter&) = delete;

  // Creates (truncates) `path` and writes a '#' header line. The parent folder must exist.
  Status open(const std::string& path, double sync_seconds = -1);
  // Continues an existing file (a resumed run): cut back to its first `keep_bytes` bytes (the
  // lines a checkpoint covers), then appends. Errors: a missing file or one shorter than that.
  Status open_append(const std::string& path, int64_t keep_bytes, double sync_seconds = -1);
  // The file's length: whole lines only.
  int64_t bytes() const { return bytes_; }
  // Appends one line. Error if not open or the write fails (naming the file, the line and the reason).
  Status write(double timestamp, const SE3& T_wc);
  // Appends "# <text>" as its own line (TUM readers skip it). `text` must be one line. Used by
  // `edgefusion run` to mark a lost frame just before its pose line: "# lost <timestamp> <reason>".
  Status write_comment(const char* text);
  // Syncs what was written to the disk now (the file stays open).
  Status flush();
  // Syncs and closes; reports a failed sync. Safe to call twice.
  Status close();
  bool is_open() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }
  int64_t lines() const { return lines_; }  // lines written, the header included

 private:
  Status append(const char* line, std::size_t n);
  int fd_ = -1;
  std::string path_;
  double sync_seconds_ = -1;
  int64_t bytes_ = 0;          // the file's length: whole lines only
  int64_t lines_ = 0;
  int64_t last_sync_ns_ = 0;   // steady clock
  bool unsynced_ = false;      // lines written since the last sync
};

// Rewrites the pose lines of a TUM file through `correct`, called with each pose line's timestamp
// and pose: when it returns true with a new pose, the line is written again with it (its timestamp
// as the line had it, the pose as TumTrajectoryWriter writes poses); otherwise the line stays as it
// was, byte for byte, as do comments and blank lines. A line repeating the previous one's timestamp
// is a pose line too. `comment` (one line, may be empty: none) goes in as "# <comment>" after the first
// line, replacing a line from an earlier rewrite that starts with the same first `comment_key` bytes.
// The file is replaced whole (written beside it, synced, renamed: io/durable_file.h), so a crash
// leaves the old version or the new one. Errors name the file and the line (a line that is not a
// pose), or the write's reason; the file is then unchanged.
struct TumRewrite {
  int64_t bytes = 0;      // the new file's length
  int64_t corrected = 0;  // pose lines written again
  int64_t kept = 0;       // pose lines left as they were
};
template <typename F>
Result<TumRewrite> rewrite_tum_poses(const std::string& path, F&& correct, const std::string& comment = {},
                                     std::size_t comment_key = 0);
namespace detail {
using PoseCorrector = bool (*)(void* context, double timestamp, SE3* T_wc);
Result<TumRewrite> rewrite_tum_poses(const std::string& path, PoseCorrector correct, void* context,
                                     const std::string& comment, std::size_t comment_key);
}  // namespace detail
template <typename F>
Result<TumRewrite> rewrite_tum_poses(const std::string& path, F&& correct, const std::string& comment,
                                     std::size_t comment_key) {
  auto call = [](void* c, double t, SE3* T) -> bool { return (*static_cast<std::remove_reference_t<F>*>(c))(t, T); };
  return detail::rewrite_tum_poses(path, call, &correct, comment, comment_key);
}

// Convenience: writes a whole trajectory.
Status write_tum_trajectory(const std::string& path, const std::vector<TimedPose>& poses);

}  // namespace ef
