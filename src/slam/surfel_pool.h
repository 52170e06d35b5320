// The surfel map's storage: a bounded pool of surfels in structure-of-arrays layout, allocated once
// from the configuration (default 1,000,000 surfels) and never resized.
//
// A surfel (ElasticFusion, Whelan et al. RSS 2015, section 3) is a disc: position, normal, radius,
// colour, a confidence (the accumulated fusion weight), the frame it was created at (init_time) and
// the frame it was last fused at (last_seen, also the time loop closure's deformation graph moves it by).
// Surfels with confidence >= the stable threshold (fusion options) are "stable" and used for tracking.
//
// Columns (one contiguous array each, 64-byte aligned, index = surfel id 0..size()-1):
//   x y z          float    position, metres, world frame
//   nx ny nz       float    unit normal, world frame
//   radius         float    disc radius, metres
//   confidence     float    accumulated weight (dimensionless, > 0)
//   color          uint32   sRGB packed as R | G << 8 | B << 16 (top byte 0)
//   init_time      int32    frame index at creation
//   last_seen      int32    frame index of the last fusion into this surfel
//   labels         kLabelBytesPerSurfel bytes: the semantic label store (issue 6 fills it; zero here)
// = kBytesPerSurfel bytes per surfel (docs/architecture.md, memory budget).
//
// Ids are dense: removing surfel i moves the last surfel into slot i (every column, labels included,
// so anything stored per surfel travels with it). Ids are therefore only stable between removals;
// index maps are rebuilt every frame and must not be kept across a removal. permute() (used by
// slam/spatial_order.h) reorders all ids at once, every column moving with its surfel.
//
// Full pool policy (SurfelPool::reserve_for_new): new surfels are created while there is room. When
// the pool is full, room is made by evicting surfels not seen for `evict_unseen_frames` frames:
// unstable ones first (never confirmed: noise and the fringe of the views), then stable ones, each
// the longest unseen first (counted in `evicted`). What the current view shows was seen within the
// last frames and stays, so the tracker keeps the model it needs, and a small pool maps what is in
// front of the camera by forgetting what it left longest ago. New surfels that still do not fit
// (the view alone needs more than the pool holds) are refused (counted in `refused`). Measured on
// 7-Scenes (docs/results.md): a 100,000 or 20,000-surfel pool tracks all 1000 frames (ATE 3.7 and
// 4.0 cm) where refusing new surfels once full lost 606 and 630 frames (68 and 64 cm).
//
// Memory: create() allocates everything; no other member allocates. Threads: not synchronised.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/options.h"
#include "core/result.h"

namespace ef::slam {

struct SurfelPoolOptions {
  // Maximum number of surfels (>= 1, at most 100,000,000). Default 1,000,000 (kBytesPerSurfel each).
  int64_t capacity = 1'000'000;
  // When full: surfels whose last_seen is at least this many frames old may be evicted to make room
  // (frames, >= 1), unstable ones first. Default 30 (about a second at 30 Hz).
  int32_t evict_unseen_frames = 30;

  // The keys `run` offers (section mapping): surfel_capacity.
  static const opt::Table<SurfelPoolOptions>& table();
  Status validate() const;
  std::string describe() const;
};

// Counters of the pool's full-pool policy and churn; totals since create().
struct SurfelPoolCounters {
  uint64_t created = 0;   // surfels appended
  uint64_t removed = 0;   // surfels removed by the map's own rules (stale, free space, merges)
  uint64_t evicted = 0;   // surfels removed to make room when the pool was full
  uint64_t refused = 0;   // new surfels not created because the pool was full
};

class SurfelPool {
 public:
  static constexpr int kLabelBytesPerSurfel = 16;
  static constexpr std::size_t kBytesPerSurfel =
      8 * sizeof(float) + sizeof(uint32_t) + 2 * sizeof(int32_t) + kLabelBytesPerSurfel;  // 60

  static Result<SurfelPool> create(const SurfelPoolOptions& options = {});
  // Bytes create() allocates for `capacity` surfels (every column rounded up to 64 bytes).
  static std::size_t bytes_for(int64_t capacity);

  SurfelPool(SurfelPool&&) noexcept = default;
  SurfelPool& operator=(SurfelPool&&) noexcept = default;

  int64_t size() const { return size_; }
  int64_t capacity() const { return options_.capacity; }
  bool full() const { return size_ == options_.capacity; }
  const SurfelPoolOptions& options() const { return options_; }
  // Bytes allocated by create() (all columns).
  std::size_t bytes() const { return bytes_; }

  // Columns (pointers stay valid for the pool's lifetime).
  float* x() { return x_; }
  float* y() { return y_; }
  float* z() { return z_; }
  float* nx() { return nx_; }
  float* ny() { return ny_; }
  float* nz() { return nz_; }
  float* radius() { return radius_; }
  float* confidence() { return confidence_; }
  uint32_t* color() { return color_; }
  int32_t* init_time() { return init_time_; }
  int32_t* last_seen() { return last_seen_; }
  uint8_t* labels() { return labels_; }  // kLabelBytesPerSurfel per surfel, surfel i at i * 16
  const float* x() const { return x_; }
  const float* y() const { return y_; }
  const float* z() const { return z_; }
  const float* nx() const { return nx_; }
  const float* ny() const { return ny_; }
  const float* nz() const { return nz_; }
  const float* radius() const { return radius_; }
  const float* confidence() const { return confidence_; }
  const uint32_t* color() const { return color_; }
  const int32_t* init_time() const { return init_time_; }
  const int32_t* last_seen() const { return last_seen_; }
  const uint8_t* labels() const { return labels_; }

  // Makes room for up to `wanted` new surfels at frame `frame` by the full-pool policy above
  // (evicting when needed) and returns how many may be appended now (<= wanted). Counts evictions;
  // the caller counts refusals with count_refused(). Unstable = confidence < stable_confidence.
  // Time: two passes over the pool, only when it is full.
  int64_t reserve_for_new(int64_t wanted, int32_t frame, float stable_confidence);
  // Appends one surfel (the caller has reserved room); returns its id, or -1 (and counts a refusal)
  // when full. Labels are cleared to zero (issue 6: "uniform").
  int64_t append(float px, float py, float pz, float pnx, float pny, float pnz, float pradius, float pconfidence,
                 uint32_t pcolor, int32_t frame);
  void count_refused(uint64_t n) { counters_.refused += n; }

  // Removes surfel `id` by moving the last surfel into its slot (see "Ids are dense" above).
  // Counted in `removed`. Callers iterating over ids remove from high ids to low, or re-visit `id`.
  void remove(int64_t id);
  // Removes every surfel whose flag is non-zero (flags: size() bytes), keeping the order of the rest.
  // One pass; counted in `removed`. Returns how many were removed.
  int64_t remove_flagged(const uint8_t* flags);
  void clear() { size_ = 0; }
  // A pool loaded from a checkpoint: its first `size` surfels were written into the columns by the
  // caller; the counters continue from `counters`. Error (kInvalidArgument) when size is outside
  // 0..capacity().
  Status set_restored(int64_t size, const SurfelPoolCounters& counters);

  const SurfelPoolCounters& counters() const { return counters_; }

  // Copies surfel `from` onto slot `to` (every column). Exposed for tests of the store's consistency.
  void copy_surfel(int64_t from, int64_t to);
  // Reorders the surfels: slot i receives the surfel that was at old_of_new[i], for i in 0..size()-1
  // (old_of_new must be a permutation of 0..size()-1; slam/spatial_order.h makes one). Every column
  // moves, labels included. `scratch` (4 x size() bytes) is overwritten. Not counted as removals.
  void permute(const int32_t* old_of_new, unsigned char* scratch);

 private:
  SurfelPool() = default;
  void evict(int64_t id);

  struct AlignedFree {
    void operator()(unsigned char* p) const;
  };
  SurfelPoolOptions options_;
  std::unique_ptr<unsigned char[], AlignedFree> block_;
  std::size_t bytes_ = 0;
  int64_t size_ = 0;
  float *x_ = nullptr, *y_ = nullptr, *z_ = nullptr, *nx_ = nullptr, *ny_ = nullptr, *nz_ = nullptr;
  float *radius_ = nullptr, *confidence_ = nullptr;
  uint32_t* color_ = nullptr;
  int32_t *init_time_ = nullptr, *last_seen_ = nullptr;
  uint8_t* labels_ = nullptr;
  SurfelPoolCounters counters_;
};

inline uint32_t pack_rgb(uint8_t r, uint8_t g, uint8_t b) {
  return static_cast<uint32_t>(r) | (static_cast<uint32_t>(g) << 8) | (static_cast<uint32_t>(b) << 16);
}
inline uint8_t unpack_r(uint32_t c) { return static_cast<uint8_t>(c & 0xFF); }
inline uint8_t unpack_g(uint32_t c) { return static_cast<uint8_t>((c >> 8) & 0xFF); }
inline uint8_t unpack_b(uint32_t c) { return static_cast<uint8_t>((c >> 16) & 0xFF); }

}  // namespace ef::slam
