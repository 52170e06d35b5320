// Map checkpoints of `edgefusion run` (issue 29): everything needed to continue a run after a kill,
// a crash or a power cut, as one snapshot file (io/snapshot_file.h, docs/snapshot_format.md).
//
// Sections:
//   META  run facts: frames mapped, the last frame's timestamp, trajectory.txt's length with their
//         lines, the working size, the pool capacity, the run's seconds so far (32 words of 8 bytes)
//   SLAM  SurfelSlam::State (poses, frame counts, the fusion sweep, the last prediction's arguments,
//         the loss in progress, relocalisations, the recent inlier average)
//   POOL  the surfel pool: its size and counters, then each column's first `size` entries
//         (x y z nx ny nz radius confidence: float; colour: uint32; init_time last_seen: int32;
//         labels: 16 bytes), host order (little-endian on every target: checked at compile time)
//   KEYF  the relocaliser's keyframes (slam/keyframe_ferns.h): count, ferns, refused, 0 (uint64),
//         then the codes (count x ferns bytes), poses (count x 7 doubles: t xyz, q xyzw) and frame
//         indices (int32); optional: a checkpoint without it resumes with no keyframes
//   CNTN  the run's counter names (name bytes, NUL-terminated), CNTV their values (uint64)
//
// In the run folder: checkpoint.efs, and checkpoint.prev.efs the one before (a corrupt newest one,
// named in a warning, falls back to it). A checkpoint holds the state after its last frame, whose
// trajectory line is synced before the snapshot is written; resuming cuts trajectory.txt back to
// that length and continues with the next frame. CNN results still in flight at the checkpoint
// (at most the CNN's two jobs, none in a deterministic run) are not in it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/result.h"
#include "core/stage_stats.h"
#include "io/snapshot_file.h"
#include "slam/surfel_slam.h"

namespace ef::pipeline {

inline constexpr const char* kCheckpointFile = "checkpoint.efs";
inline constexpr const char* kPreviousCheckpointFile = "checkpoint.prev.efs";

struct CheckpointMeta {
  int64_t frames = 0;             // frames mapped: the next frame's number
  double last_timestamp = 0;      // of the last mapped frame, seconds
  int64_t trajectory_bytes = 0;   // trajectory.txt's length up to that frame's line
  int width = 0, height = 0;      // the working resolution
  int64_t capacity = 0;           // the pool's
  double seconds = 0;             // wall time of the run so far (all its sessions)
  bool labels = false;            // the surfels carry labels (a run with labels on)
};

// Writes <folder>/checkpoint.efs whole (the earlier one kept as checkpoint.prev.efs). `names`
// is scratch for the counter names, reused between calls (it grows once). Errors name the file.
Status write_checkpoint(const std::string& folder, const CheckpointMeta& meta, const slam::SurfelSlam& slam,
                        const StageStats& stats, std::string& names);

// The newest valid checkpoint of a run folder: checkpoint.efs, or checkpoint.prev.efs when the
// newest is missing or corrupt (`warning` then says which and why). Error: neither is usable (each
// named with its fault).
struct FoundCheckpoint {
  std::unique_ptr<SnapshotReader> reader;
  CheckpointMeta meta;
  std::string warning;
};
Result<FoundCheckpoint> find_checkpoint(const std::string& folder);

// The checkpoint's surfels alone, in a pool of just their number (edgefusion export).
Result<slam::SurfelPool> load_checkpoint_pool(const FoundCheckpoint& found);

// Loads the checkpoint into `slam` (created with the run's options: the capacity must hold the
// checkpoint's surfels and the working size must match) and the counters it names into `stats`.
// Errors name the file and what does not fit.
Status restore_checkpoint(const FoundCheckpoint& found, slam::SurfelSlam& slam, StageStats& stats);

}  // namespace ef::pipeline
