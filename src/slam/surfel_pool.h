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
// Block bounds (for culling): for every run of kBoundsBlock consecutive ids, a box holding the
// centres of its surfels and the range of their last_seen. Renderers (slam/model_prediction.h) skip
// a block whose box is outside the view or whose times are outside the window they draw, so that a
// frame's cost follows what is in view, not the size of the map. The bounds are conservative: a box
// may be larger than its surfels (removals do not shrink it; the next refresh does), never smaller.
// They are kept current by every writer of positions and times that goes through the pool
// (append, remove, set_position, set_last_seen, permute, remove_flagged); taking a mutable x(), y(),
// z() or last_seen() column marks them stale as a whole (the caller may write anything), and
// refresh_bounds() then recomputes them (one pass over the pool). Stale bounds are never used:
// renderers then visit every block.
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

  // Ids per block of the block bounds (a renderer's block of work, slam/model_prediction.cpp).
  static constexpr int kBoundsBlock = 256;
  // One block's bounds: lo/hi of the centres (metres, world), seen_min/seen_max of last_seen
  // (frames). A block no surfel has entered since its reset has lo > hi (an empty box).
  struct BlockBounds {
    float lo[3];
    float hi[3];
    int32_t seen_min;
    int32_t seen_max;
  };

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

  // Columns (pointers stay valid for the pool's lifetime). Taking a mutable x(), y(), z() or
  // last_seen() marks the block bounds stale (see above): write positions and times on hot paths
  // with set_position() / set_last_seen() instead, and read through a const pool.
  float* x() { bounds_current_ = false; return x_; }
  float* y() { bounds_current_ = false; return y_; }
  float* z() { bounds_current_ = false; return z_; }
  float* nx() { return nx_; }
  float* ny() { return ny_; }
  float* nz() { return nz_; }
  float* radius() { return radius_; }
  float* confidence() { return confidence_; }
  uint32_t* color() { return color_; }
  int32_t* init_time() { return init_time_; }
  int32_t* last_seen() { bounds_current_ = false; return last_seen_; }
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

  // Writes surfel `id`'s centre (metres, world) / last_seen (frame), growing its block's bounds.
  void set_position(int64_t id, float px, float py, float pz) {
    x_[id] = px;
    y_[id] = py;
    z_[id] = pz;
    grow_bounds(id);
  }
  void set_last_seen(int64_t id, int32_t frame) {
    last_seen_[id] = frame;
    grow_bounds(id);
  }

  // Block bounds of ids [b kBoundsBlock, (b + 1) kBoundsBlock) for b < blocks(); meaningful only
  // while bounds_current(). refresh_bounds() recomputes every block of a stale pool (a pass over the
  // positions and times; counted in bounds_refreshes()) and does nothing to a current one.
  int64_t blocks() const { return (size_ + kBoundsBlock - 1) / kBoundsBlock; }
  bool bounds_current() const { return bounds_current_; }
  const BlockBounds* block_bounds() const { return bounds_.get(); }
  void refresh_bounds();
  uint64_t bounds_refreshes() const { return bounds_refreshes_; }

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
  // Widens the bounds of id's block to its centre and last_seen (a block's first id resets them).
  void grow_bounds(int64_t id) {
    BlockBounds& b = bounds_[static_cast<std::size_t>(id / kBoundsBlock)];
    const float p[3] = {x_[id], y_[id], z_[id]};
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = p[a] < b.lo[a] ? p[a] : b.lo[a];
      b.hi[a] = p[a] > b.hi[a] ? p[a] : b.hi[a];
    }
    b.seen_min = last_seen_[id] < b.seen_min ? last_seen_[id] : b.seen_min;
    b.seen_max = last_seen_[id] > b.seen_max ? last_seen_[id] : b.seen_max;
  }
  void reset_bounds(int64_t block);

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
  std::unique_ptr<BlockBounds[]> bounds_;  // ceil(capacity / kBoundsBlock)
  bool bounds_current_ = true;
  uint64_t bounds_refreshes_ = 0;
  SurfelPoolCounters counters_;
};

inline uint32_t pack_rgb(uint8_t r, uint8_t g, uint8_t b) {
  return static_cast<uint32_t>(r) | (static_cast<uint32_t>(g) << 8) | (static_cast<uint32_t>(b) << 16);
}
inline uint8_t unpack_r(uint32_t c) { return static_cast<uint8_t>(c & 0xFF); }
inline uint8_t unpack_g(uint32_t c) { return static_cast<uint8_t>((c >> 8) & 0xFF); }
inline uint8_t unpack_b(uint32_t c) { return static_cast<uint8_t>((c >> 16) & 0xFF); }

}  // namespace ef::slam
