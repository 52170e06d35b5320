#include "slam/pose_history.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/deformation_graph.h"

namespace ef::slam {

namespace {

// A record: the timestamp, then the pose's SE3 words.
void put(double* w, double timestamp, const SE3& T) {
  w[0] = timestamp;
  T.to_words(w + 1);
}

SE3 get(const double* w) { return SE3::from_words(w + 1); }

}  // namespace

Result<PoseHistory> PoseHistory::create(int64_t capacity) {
  if (capacity < 0) return error(ErrorCode::kInvalidArgument, "pose history: capacity " + std::to_string(capacity) + " < 0");
  PoseHistory h;
  h.capacity_ = capacity;
  if (capacity > 0) h.words_.reset(new double[static_cast<std::size_t>(capacity) * kWords]());
  return h;
}

void PoseHistory::push(int64_t frame, double timestamp, const SE3& T_world_cam) {
  if (capacity_ == 0) return;
  if (frame != next_ || count_ == 0) {  // the first frame, or not the next one: start again
    count_ = 0;
    start_ = frame;
  }
  put(record(frame), timestamp, T_world_cam);
  next_ = frame + 1;
  if (count_ < capacity_) ++count_;
}

void PoseHistory::deform(const DeformationGraph& graph) {
  if (capacity_ == 0) return;
  for (int64_t f = first_frame(); f < next_; ++f) {
    double* w = record(f);
    put(w, w[0], graph.apply_pose(get(w), static_cast<int32_t>(f)));
  }
  ++deformations_;
}

bool PoseHistory::at_frame(int64_t frame, SE3* T_world_cam) const {
  if (count_ == 0 || frame < first_frame() || frame >= next_) return false;
  *T_world_cam = get(record(frame));
  return true;
}

bool PoseHistory::at_time(double timestamp, SE3* T_world_cam) const {
  constexpr double kTolerance = 0.5e-6;  // seconds: trajectory.txt writes 6 decimals
  // The first held frame not before timestamp - tolerance.
  int64_t lo = first_frame(), hi = next_;
  while (lo < hi) {
    const int64_t mid = lo + (hi - lo) / 2;
    if (record(mid)[0] < timestamp - kTolerance) lo = mid + 1;
    else hi = mid;
  }
  if (lo >= next_ || std::fabs(record(lo)[0] - timestamp) > kTolerance) return false;
  *T_world_cam = get(record(lo));
  return true;
}

int PoseHistory::runs(const double* data[2], int64_t records[2]) const {
  if (count_ == 0) return 0;
  const int64_t first_slot = first_frame() % capacity_;
  const int64_t head = std::min(count_, capacity_ - first_slot);
  data[0] = words_.get() + first_slot * kWords;
  records[0] = head;
  if (head == count_) return 1;
  data[1] = words_.get();
  records[1] = count_ - head;
  return 2;
}

Status PoseHistory::restore(int64_t first, int64_t count, int64_t overwritten, int64_t deformations,
                            const double* records) {
  if (first < 0 || count < 0 || overwritten < 0 || deformations < 0 || overwritten > first)
    return error(ErrorCode::kCorruptData, "pose history: impossible frame counts");
  for (int64_t i = 0; i < count; ++i) {
    const double* w = records + i * kWords;
    if (!std::isfinite(w[0]) || !SE3::words_are_pose(w + 1))
      return error(ErrorCode::kCorruptData, "pose history: frame " + std::to_string(first + i) +
                                                "'s record is not a timestamp and a rigid pose");
    if (i > 0 && !(w[0] >= w[-kWords]))
      return error(ErrorCode::kCorruptData, "pose history: timestamps go back at frame " +
                                                std::to_string(first + i));
  }
  count_ = 0;
  start_ = first - overwritten;
  next_ = first;
  deformations_ = deformations;
  if (capacity_ == 0) return Status::success();
  const int64_t skip = std::max<int64_t>(0, count - capacity_);  // a smaller capacity keeps the newest
  for (int64_t i = skip; i < count; ++i) std::copy(records + i * kWords, records + (i + 1) * kWords, record(first + i));
  next_ = first + count;
  count_ = count - skip;
  return Status::success();
}

}  // namespace ef::slam
