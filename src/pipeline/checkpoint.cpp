#include "pipeline/checkpoint.h"

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <utility>

namespace ef::pipeline {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "checkpoints store the pool's columns in host order");

namespace {

constexpr char kMeta[4] = {'M', 'E', 'T', 'A'}, kSlam[4] = {'S', 'L', 'A', 'M'}, kPool[4] = {'P', 'O', 'O', 'L'},
               kCounterNames[4] = {'C', 'N', 'T', 'N'}, kCounterValues[4] = {'C', 'N', 'T', 'V'},
               kKeyframes[4] = {'K', 'E', 'Y', 'F'}, kPoses[4] = {'P', 'O', 'S', 'E'};
constexpr int kKeyframeHeaderWords = 4, kPoseHeaderWords = 4;
constexpr int kMetaWords = 32, kSlamWords = 32, kPoolHeaderWords = 8;

uint64_t word(double v) {
  uint64_t w;
  std::memcpy(&w, &v, 8);
  return w;
}
double as_double(uint64_t w) {
  double v;
  std::memcpy(&v, &w, 8);
  return v;
}

// An SE3 as 7 words (SE3::to_words).
void put_pose(uint64_t* w, const SE3& T) {
  double v[SE3::kWords];
  T.to_words(v);
  for (int i = 0; i < SE3::kWords; ++i) w[i] = word(v[i]);
}
// Bit for bit as it was saved (SE3's constructor would normalise the quaternion again, moving its
// last bits, and the resumed run would drift from the uninterrupted one by rounding). A stored
// quaternion far from unit length is a corrupt file.
Result<SE3> get_pose(const uint64_t* w) {
  double v[SE3::kWords];
  for (int i = 0; i < SE3::kWords; ++i) v[i] = as_double(w[i]);
  if (!SE3::words_are_pose(v)) return error(ErrorCode::kCorruptData, "a pose that is not a rigid transform");
  return SE3::from_words(v);
}

// The pool's columns in file order: (pointer, bytes per surfel).
constexpr std::size_t kColumns = 12;
template <class Pool, class Ptr>
std::array<std::pair<Ptr, std::size_t>, kColumns> columns(Pool& p) {
  return {{{p.x(), 4},
           {p.y(), 4},
           {p.z(), 4},
           {p.nx(), 4},
           {p.ny(), 4},
           {p.nz(), 4},
           {p.radius(), 4},
           {p.confidence(), 4},
           {p.color(), 4},
           {p.init_time(), 4},
           {p.last_seen(), 4},
           {p.labels(), slam::SurfelPool::kLabelBytesPerSurfel}}};
}
// The columns above are the pool's whole surfel (read_pool_header sizes the section with it).
static_assert(11 * 4 + slam::SurfelPool::kLabelBytesPerSurfel == slam::SurfelPool::kBytesPerSurfel,
              "a checkpoint's POOL columns are every byte of a surfel");

Result<CheckpointMeta> read_meta(const SnapshotReader& r) {
  uint64_t w[kMetaWords];
  EF_RETURN_IF_ERROR(r.read(kMeta, w, sizeof w));
  CheckpointMeta m;
  m.frames = static_cast<int64_t>(w[0]);
  m.last_timestamp = as_double(w[1]);
  m.trajectory_bytes = static_cast<int64_t>(w[2]);
  m.width = static_cast<int>(w[3]);
  m.height = static_cast<int>(w[4]);
  m.capacity = static_cast<int64_t>(w[5]);
  m.seconds = as_double(w[6]);
  m.labels = w[7] != 0;
  if (m.frames < 0 || m.trajectory_bytes < 0 || m.width <= 0 || m.height <= 0 || m.capacity <= 0)
    return error(ErrorCode::kCorruptData, r.path() + ": section META holds impossible values");
  return m;
}

}  // namespace

Status write_checkpoint(const std::string& folder, const CheckpointMeta& meta, const slam::SurfelSlam& slam,
                        const StageStats& stats, std::string& names) {
  const std::filesystem::path dir(folder);
  SnapshotWriter w;
  EF_RETURN_IF_ERROR(w.open((dir / kCheckpointFile).string()));

  uint64_t m[kMetaWords] = {};
  m[0] = static_cast<uint64_t>(meta.frames);
  m[1] = word(meta.last_timestamp);
  m[2] = static_cast<uint64_t>(meta.trajectory_bytes);
  m[3] = static_cast<uint64_t>(meta.width);
  m[4] = static_cast<uint64_t>(meta.height);
  m[5] = static_cast<uint64_t>(meta.capacity);
  m[6] = word(meta.seconds);
  m[7] = meta.labels ? 1 : 0;
  EF_RETURN_IF_ERROR(w.section(kMeta, m, sizeof m));

  const slam::SurfelSlam::State st = slam.state();
  uint64_t s[kSlamWords] = {};
  put_pose(s + 0, st.T_world_last);
  put_pose(s + 7, st.last_motion);
  s[14] = static_cast<uint64_t>(st.frames);
  s[15] = static_cast<uint64_t>(st.fused_frames);
  s[16] = static_cast<uint64_t>(st.lost_frames);
  s[17] = static_cast<uint64_t>(st.sweep_cursor);
  s[18] = static_cast<uint64_t>(static_cast<int64_t>(st.predicted_frame));
  s[19] = word(static_cast<double>(st.predicted_min_confidence));
  s[20] = static_cast<uint64_t>(st.lost_run);
  s[21] = static_cast<uint64_t>(st.relocalisations);
  s[22] = word(st.inlier_reference);
  s[23] = static_cast<uint64_t>(st.inlier_samples);
  EF_RETURN_IF_ERROR(w.section(kSlam, s, sizeof s));

  // The relocaliser's keyframes straight from the database's arrays.
  const slam::KeyframeFerns& kf = slam.keyframes();
  const uint64_t kn = static_cast<uint64_t>(kf.size());
  const uint64_t kh[kKeyframeHeaderWords] = {kn, static_cast<uint64_t>(kf.ferns()), kf.refused(), 0};
  const SnapshotWriter::Part kparts[4] = {{kh, sizeof kh},
                                          {kf.code(0), kn * static_cast<uint64_t>(kf.ferns())},
                                          {kf.pose_words(), kn * SE3::kWords * sizeof(double)},
                                          {kf.frames(), kn * sizeof(int32_t)}};
  EF_RETURN_IF_ERROR(w.section(kKeyframes, kparts, 4));

  // The pose history (loop closure corrects it) straight from its ring.
  const slam::PoseHistory& history = slam.pose_history();
  const uint64_t hh[kPoseHeaderWords] = {static_cast<uint64_t>(history.first_frame()), static_cast<uint64_t>(history.size()),
                                         static_cast<uint64_t>(history.overwritten()),
                                         static_cast<uint64_t>(history.deformations())};
  const double* runs[2] = {nullptr, nullptr};
  int64_t run_records[2] = {0, 0};
  const int run_count = history.runs(runs, run_records);
  SnapshotWriter::Part hparts[3] = {{hh, sizeof hh}, {nullptr, 0}, {nullptr, 0}};
  for (int i = 0; i < run_count; ++i)
    hparts[1 + i] = {runs[i], static_cast<std::size_t>(run_records[i]) * slam::PoseHistory::kBytesPerFrame};
  EF_RETURN_IF_ERROR(w.section(kPoses, hparts, 1 + static_cast<std::size_t>(run_count)));

  // The pool straight from its columns: no copy.
  const slam::SurfelPool& pool = slam.pool();
  const slam::SurfelPoolCounters& pc = pool.counters();
  const uint64_t n = static_cast<uint64_t>(pool.size());
  const uint64_t ph[kPoolHeaderWords] = {n, pc.created, pc.removed, pc.evicted, pc.refused, 0, 0, 0};
  SnapshotWriter::Part parts[1 + kColumns];
  parts[0] = {ph, sizeof ph};
  const auto cols = columns<const slam::SurfelPool, const void*>(pool);
  for (std::size_t c = 0; c < kColumns; ++c) parts[1 + c] = {cols[c].first, cols[c].second * n};
  EF_RETURN_IF_ERROR(w.section(kPool, parts, 1 + kColumns));

  // Counter names (built once; the set only grows) and values.
  std::size_t name_count = 0;
  for (std::size_t i = 0; i < names.size(); ++i) name_count += names[i] == '\0';
  if (name_count != stats.num_counters()) {
    names.clear();
    for (std::size_t i = 0; i < stats.num_counters(); ++i) {
      names += stats.counter_name(static_cast<int>(i));
      names += '\0';
    }
  }
  EF_RETURN_IF_ERROR(w.section(kCounterNames, names.data(), names.size()));
  uint64_t values[64] = {};
  const std::size_t counters = std::min<std::size_t>(stats.num_counters(), 64);
  for (std::size_t i = 0; i < counters; ++i) values[i] = stats.counter(static_cast<int>(i));
  EF_RETURN_IF_ERROR(w.section(kCounterValues, values, counters * sizeof(uint64_t)));

  return w.commit((dir / kPreviousCheckpointFile).string());
}

Result<FoundCheckpoint> find_checkpoint(const std::string& folder) {
  const std::filesystem::path dir(folder);
  std::string faults;
  for (const char* name : {kCheckpointFile, kPreviousCheckpointFile}) {
    FoundCheckpoint found;
    found.reader = std::make_unique<SnapshotReader>();
    Status s = found.reader->open((dir / name).string());
    if (s.ok()) {
      auto meta = read_meta(*found.reader);
      if (meta.ok()) {
        found.meta = *meta;
        if (!faults.empty()) found.warning = faults + "; continuing from " + (dir / name).string();
        return found;
      }
      s = meta.error();
    }
    faults += (faults.empty() ? "" : "; ") + s.error().message;
  }
  return error(ErrorCode::kNotFound, "no usable checkpoint in '" + folder + "': " + faults);
}

namespace {

// The POOL section's surfel count and counters. The count must be the one the section's length
// holds: a pool is allocated for it (export, view) before the columns are read, so a corrupt count
// must never size an allocation (a 3 KB file claiming 50 million surfels asked for 3 GB; issue 34).
Result<std::pair<int64_t, slam::SurfelPoolCounters>> read_pool_header(const SnapshotReader& r) {
  uint64_t ph[kPoolHeaderWords];
  EF_RETURN_IF_ERROR(r.read(kPool, ph, sizeof ph));
  const int64_t n = static_cast<int64_t>(ph[0]);
  if (n < 0 || ph[0] > (uint64_t(1) << 40))
    return error(ErrorCode::kCorruptData, r.path() + ": section POOL holds an impossible surfel count");
  // n <= 2^40: the product stays far below 2^64.
  const uint64_t expected = kPoolHeaderWords * 8 + ph[0] * slam::SurfelPool::kBytesPerSurfel;
  if (r.size(kPool) != expected)
    return error(ErrorCode::kCorruptData, r.path() + ": section POOL has " + std::to_string(r.size(kPool)) +
                                              " bytes; " + std::to_string(n) + " surfels take " +
                                              std::to_string(expected));
  return std::make_pair(n, slam::SurfelPoolCounters{ph[1], ph[2], ph[3], ph[4]});
}

// Reads the POOL section's columns into `pool` (capacity checked by the caller).
Status read_pool(const SnapshotReader& r, int64_t n, const slam::SurfelPoolCounters& counters, slam::SurfelPool& pool) {
  if (n > pool.capacity())
    return error(ErrorCode::kInvalidArgument, r.path() + ": holds " + std::to_string(n) +
                                                  " surfels, more than the pool's capacity of " +
                                                  std::to_string(pool.capacity()) +
                                                  " (mapping.surfel_capacity must be at least that)");
  uint64_t expected = kPoolHeaderWords * 8;
  const auto cols = columns<slam::SurfelPool, void*>(pool);
  for (const auto& c : cols) expected += c.second * static_cast<uint64_t>(n);
  if (r.size(kPool) != expected)
    return error(ErrorCode::kCorruptData, r.path() + ": section POOL has " + std::to_string(r.size(kPool)) +
                                              " bytes; " + std::to_string(n) + " surfels take " +
                                              std::to_string(expected));
  uint64_t offset = kPoolHeaderWords * 8;
  for (const auto& c : cols) {
    const std::size_t bytes = c.second * static_cast<std::size_t>(n);
    EF_RETURN_IF_ERROR(r.read(kPool, c.first, bytes, offset));
    offset += bytes;
  }
  return pool.set_restored(n, counters);
}

// The KEYF section into the relocaliser's database. A checkpoint without it (written before
// relocalisation existed) leaves the database empty: it fills again from the frames that follow.
Status read_keyframes(const SnapshotReader& r, slam::KeyframeFerns& kf) {
  if (!r.has(kKeyframes)) return Status::success();
  uint64_t kh[kKeyframeHeaderWords];
  EF_RETURN_IF_ERROR(r.read(kKeyframes, kh, sizeof kh));
  const uint64_t n = kh[0], ferns = kh[1];
  if (ferns != static_cast<uint64_t>(kf.ferns()))
    return error(ErrorCode::kInvalidArgument, r.path() + ": keyframes encoded with " + std::to_string(ferns) +
                                                  " ferns; this run has mapping.fern_count " +
                                                  std::to_string(kf.ferns()) + " (they must match to resume)");
  if (n > static_cast<uint64_t>(kf.capacity()))
    return error(ErrorCode::kInvalidArgument, r.path() + ": holds " + std::to_string(n) +
                                                  " keyframes, more than mapping.keyframe_capacity " +
                                                  std::to_string(kf.capacity()));
  const uint64_t expected = sizeof kh + n * (ferns + SE3::kWords * sizeof(double) + sizeof(int32_t));
  if (r.size(kKeyframes) != expected)
    return error(ErrorCode::kCorruptData, r.path() + ": section KEYF has " + std::to_string(r.size(kKeyframes)) +
                                              " bytes; " + std::to_string(n) + " keyframes take " +
                                              std::to_string(expected));
  std::vector<uint8_t> codes(n * ferns);
  std::vector<double> poses(n * SE3::kWords);
  std::vector<int32_t> frames(n);
  uint64_t offset = sizeof kh;
  EF_RETURN_IF_ERROR(r.read(kKeyframes, codes.data(), codes.size(), offset));
  offset += codes.size();
  EF_RETURN_IF_ERROR(r.read(kKeyframes, poses.data(), poses.size() * sizeof(double), offset));
  offset += poses.size() * sizeof(double);
  EF_RETURN_IF_ERROR(r.read(kKeyframes, frames.data(), frames.size() * sizeof(int32_t), offset));
  Status s = kf.restore(static_cast<int32_t>(n), codes.data(), poses.data(), frames.data(), kh[2]);
  if (!s.ok()) return error(ErrorCode::kCorruptData, r.path() + ": " + s.error().message);
  return Status::success();
}

// The POSE section into the pose history. A checkpoint without it (written before loop closure
// corrected poses) leaves the history empty: the frames before it keep their tracked lines.
Status read_pose_history(const SnapshotReader& r, slam::PoseHistory& history) {
  if (!r.has(kPoses)) return Status::success();
  uint64_t hh[kPoseHeaderWords];
  EF_RETURN_IF_ERROR(r.read(kPoses, hh, sizeof hh));
  const uint64_t count = hh[1];
  const uint64_t bytes = r.size(kPoses) - sizeof hh;
  if (r.size(kPoses) < sizeof hh || count > bytes / slam::PoseHistory::kBytesPerFrame ||
      bytes != count * slam::PoseHistory::kBytesPerFrame)
    return error(ErrorCode::kCorruptData, r.path() + ": section POSE has " + std::to_string(r.size(kPoses)) +
                                              " bytes, not " + std::to_string(count) + " pose records");
  std::vector<double> records(count * slam::PoseHistory::kWords);
  EF_RETURN_IF_ERROR(r.read(kPoses, records.data(), records.size() * sizeof(double), sizeof hh));
  Status s = history.restore(static_cast<int64_t>(hh[0]), static_cast<int64_t>(count), static_cast<int64_t>(hh[2]),
                             static_cast<int64_t>(hh[3]), records.data());
  if (!s.ok()) return error(ErrorCode::kCorruptData, r.path() + ": " + s.error().message);
  return Status::success();
}

}  // namespace

Result<slam::SurfelPool> load_checkpoint_pool(const FoundCheckpoint& found) {
  auto header = read_pool_header(*found.reader);
  if (!header.ok()) return header.take_error();
  slam::SurfelPoolOptions o;
  o.capacity = std::max<int64_t>(header->first, 1);
  auto pool = slam::SurfelPool::create(o);
  if (!pool.ok()) return pool.take_error();
  EF_RETURN_IF_ERROR(read_pool(*found.reader, header->first, header->second, *pool));
  return std::move(*pool);
}

Status restore_checkpoint(const FoundCheckpoint& found, slam::SurfelSlam& slam, StageStats& stats) {
  const SnapshotReader& r = *found.reader;
  auto header = read_pool_header(r);
  if (!header.ok()) return header.take_error();
  const int64_t n = header->first;
  EF_RETURN_IF_ERROR(read_pool(r, n, header->second, slam.pool_for_restore()));

  uint64_t s[kSlamWords];
  EF_RETURN_IF_ERROR(r.read(kSlam, s, sizeof s));
  slam::SurfelSlam::State st;
  auto last = get_pose(s + 0), motion = get_pose(s + 7);
  if (!last.ok() || !motion.ok())
    return error(ErrorCode::kCorruptData, r.path() + ": section SLAM: " + (last.ok() ? motion : last).error().message);
  st.T_world_last = *last;
  st.last_motion = *motion;
  st.frames = static_cast<int64_t>(s[14]);
  st.fused_frames = static_cast<int64_t>(s[15]);
  st.lost_frames = static_cast<int64_t>(s[16]);
  st.sweep_cursor = static_cast<int64_t>(s[17]);
  st.predicted_frame = static_cast<int32_t>(static_cast<int64_t>(s[18]));
  st.predicted_min_confidence = static_cast<float>(as_double(s[19]));
  st.lost_run = static_cast<int64_t>(s[20]);
  st.relocalisations = static_cast<int64_t>(s[21]);
  st.inlier_reference = as_double(s[22]);
  st.inlier_samples = static_cast<int64_t>(s[23]);
  if (st.frames != found.meta.frames || st.sweep_cursor < 0 || st.sweep_cursor > n)
    return error(ErrorCode::kCorruptData, r.path() + ": sections SLAM and META disagree");
  EF_RETURN_IF_ERROR(slam.restore(st));
  EF_RETURN_IF_ERROR(read_keyframes(r, slam.keyframes_for_restore()));
  EF_RETURN_IF_ERROR(read_pose_history(r, slam.pose_history_for_restore()));

  // Counters by name: a name this run does not have is left out.
  std::string names(static_cast<std::size_t>(r.size(kCounterNames)), '\0');
  EF_RETURN_IF_ERROR(r.read(kCounterNames, names.data(), names.size()));
  std::vector<uint64_t> values(static_cast<std::size_t>(r.size(kCounterValues) / sizeof(uint64_t)));
  EF_RETURN_IF_ERROR(r.read(kCounterValues, values.data(), values.size() * sizeof(uint64_t)));
  std::size_t i = 0, start = 0;
  for (std::size_t k = 0; k < names.size() && i < values.size(); ++k) {
    if (names[k] != '\0') continue;
    const int id = stats.counter_id(std::string_view(names).substr(start, k - start));
    if (id >= 0) stats.set_counter(id, values[i]);
    ++i;
    start = k + 1;
  }
  return Status::success();
}

}  // namespace ef::pipeline
