// The camera poses of the frames mapped, kept so that a loop closure can correct them: after a
// closure deforms the map, every pose held here is moved by the same deformation (a camera at frame
// tau as DeformationGraph::apply_pose moves it), and at the end of a run trajectory.txt is rewritten
// with them (pipeline/mapping_stage.h), so the trajectory stays in the map's frame.
//
// A ring of `capacity` records in frame order, each 8 doubles: the source timestamp (seconds) and
// the camera-to-world pose (tx ty tz in metres, qx qy qz qw). A run longer than the capacity keeps
// the newest frames; the older frames' lines stay as they were tracked (overwritten() counts them).
// Lookup by frame index is O(1) (a frame's slot is its index modulo the capacity), by timestamp a
// binary search (timestamps increase with the frame index).
//
// Memory: create() allocates capacity x 64 bytes (54,000 frames, 30 minutes at 30 Hz: 3.5 MB);
// push(), deform() and the lookups allocate nothing. Threads: not synchronised (the mapping thread's).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "core/result.h"
#include "core/se3.h"

namespace ef::slam {

class DeformationGraph;

class PoseHistory {
 public:
  static constexpr int kWords = 1 + SE3::kWords;  // doubles a record: timestamp, then the pose (SE3::to_words)
  static constexpr std::size_t kBytesPerFrame = kWords * sizeof(double);
  // capacity >= 0 frames (0: keeps nothing).
  static Result<PoseHistory> create(int64_t capacity);
  static std::size_t bytes_for(int64_t capacity) { return static_cast<std::size_t>(capacity) * kBytesPerFrame; }
  std::size_t bytes() const { return bytes_for(capacity_); }

  // Records frame `frame` at `timestamp` seconds. Frames come one after the other; one that is not
  // the next starts the history again.
  void push(int64_t frame, double timestamp, const SE3& T_world_cam);
  // Every held pose moved by the deformation (its frame index as the camera's time); counted.
  void deform(const DeformationGraph& graph);

  // The pose of frame `frame`; false when it is not held.
  bool at_frame(int64_t frame, SE3* T_world_cam) const;
  // The pose recorded at `timestamp` (within 0.5 microseconds: trajectory.txt's 6 decimals); false
  // when none is held.
  bool at_time(double timestamp, SE3* T_world_cam) const;

  int64_t capacity() const { return capacity_; }
  int64_t size() const { return count_; }
  int64_t first_frame() const { return next_ - count_; }  // the oldest frame held
  int64_t overwritten() const { return next_ - count_ - start_; }  // frames recorded and no longer held
  int64_t deformations() const { return deformations_; }  // deform() calls: the poses differ from tracking

  // For checkpoints: the held records oldest first, as at most two runs of the ring (kWords doubles a
  // record); returns how many runs.
  int runs(const double* data[2], int64_t records[2]) const;
  // Restores what a checkpoint kept: `count` records (kWords doubles each, oldest first) of frames
  // first.. first + count - 1, `overwritten` frames before them no longer held. A capacity smaller
  // than count keeps the newest. Errors (kCorruptData): negative counts, a record that is not a
  // timestamp and a rigid pose, timestamps that go back.
  Status restore(int64_t first, int64_t count, int64_t overwritten, int64_t deformations, const double* records);

 private:
  PoseHistory() = default;
  double* record(int64_t frame) const { return words_.get() + static_cast<std::size_t>(frame % capacity_) * kWords; }
  int64_t capacity_ = 0;
  int64_t count_ = 0;  // frames held
  int64_t next_ = 0;   // the frame index after the newest
  int64_t start_ = 0;  // the first frame recorded since the history (re)started
  int64_t deformations_ = 0;
  std::unique_ptr<double[]> words_;
};

}  // namespace ef::slam
