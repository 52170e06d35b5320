// Keeps the surfel pool in spatial order, so that surfels near each other in space are near each
// other in memory.
//
// Why: prediction and fusion visit the surfels a camera sees in image order, and their ids follow
// creation order broken up by swap-removal (slam/surfel_pool.h). Once the pool outgrows the caches
// (28 MB of columns at 470k surfels), every candidate a pixel looks at is a cache miss in every
// column. Grouped by space, the surfels one image row sees fill a few hundred kilobytes of the pool
// that the next rows visit again.
//
// How: every `every_frames` frames the pool is bucketed by the cubic cell of side `cell_m` that
// holds each surfel's centre (counting sort on the cells' Morton code; cell coordinates wrap every
// 2^kBitsPerAxis cells, which only puts far-apart cells in one bucket), keeping the present order
// within a cell, and SurfelPool::permute() moves every column. Surfels created since the last pass
// are appended at the end in image order, which is itself spatially coherent.
//
// Ids change, as with any removal: the caller (SurfelSlam) reorders between fusion and prediction,
// so the index map is rendered from the reordered pool. Nothing else keeps ids across frames; the
// fusion's round-robin lifetime sweep (surfel_fusion.h) goes on at the same position over the new
// ids, so a surfel may wait one sweep longer for its lifetime check.
//
// Memory: create() allocates 8 bytes per surfel of capacity (the order and a gather scratch) and a
// 1 MiB histogram; reorder() does not allocate. Cost: a few passes over the pool (measured in
// docs/results.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/result.h"
#include "slam/surfel_pool.h"

namespace ef::slam {

struct SpatialOrderOptions {
  // Frames between two reorderings of the pool (>= 0; 0 = never). Default 30: about one second of
  // camera frames, in which swap-removal and new surfels disturb the order only in part.
  int32_t every_frames = 30;
  // Edge of the cubic cells surfels are grouped by, metres (> 0, finite). Default 0.1 m: at 320x240
  // a cell seen from 2 m spans about 14 working pixels, so a pixel's candidates share a few cells.
  float cell_m = 0.1f;

  Status validate() const;
  std::string describe() const;
};

class SpatialOrder {
 public:
  static constexpr int kBitsPerAxis = 6;  // cells per axis before the coordinates wrap: 64
  static constexpr int kKeys = 1 << (3 * kBitsPerAxis);
  // Bytes create() allocates for a pool of `capacity` surfels.
  static std::size_t bytes_for(int64_t capacity);

  // Errors (kInvalidArgument): bad options or capacity < 1.
  static Result<SpatialOrder> create(int64_t capacity, const SpatialOrderOptions& options = {});
  SpatialOrder(SpatialOrder&&) noexcept = default;
  SpatialOrder& operator=(SpatialOrder&&) noexcept = default;

  // Whether the pass is due after the fused frame of 0-based index `fused_index` (counting fused
  // frames only): the every_frames-th, 2 every_frames-th, ... fused frame.
  bool due(int64_t fused_index) const {
    return options_.every_frames > 0 && (fused_index + 1) % options_.every_frames == 0;
  }
  // Reorders `pool` (size() <= the capacity given to create(); a larger pool is an error,
  // kInvalidArgument, and the pool is untouched). No heap allocation.
  Status reorder(SurfelPool& pool);

  const SpatialOrderOptions& options() const { return options_; }
  std::size_t bytes() const { return bytes_for(capacity_); }

 private:
  SpatialOrder() = default;

  SpatialOrderOptions options_;
  int64_t capacity_ = 0;
  std::unique_ptr<int32_t[]> order_;     // capacity: new slot -> old id
  std::unique_ptr<uint32_t[]> key_;      // capacity: each surfel's cell key, then the gather scratch
  std::unique_ptr<uint32_t[]> start_;    // kKeys: the next slot of each cell
};

}  // namespace ef::slam
