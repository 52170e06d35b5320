// Spatial order of the surfel pool; see spatial_order.h.
#include "slam/spatial_order.h"

#include <cmath>
#include <cstring>
#include <sstream>

namespace ef::slam {

namespace {

// Bits 0..5 of v spread to bits 0, 3, 6, .., 15 (one axis of a 3D Morton code).
constexpr uint32_t spread_bits(uint32_t v) {
  uint32_t out = 0;
  for (int b = 0; b < SpatialOrder::kBitsPerAxis; ++b) out |= ((v >> b) & 1u) << (3 * b);
  return out;
}

struct SpreadTable {
  uint32_t v[1 << SpatialOrder::kBitsPerAxis];
  constexpr SpreadTable() : v() {
    for (uint32_t i = 0; i < (1u << SpatialOrder::kBitsPerAxis); ++i) v[i] = spread_bits(i);
  }
};
constexpr SpreadTable kSpread;

// The wrapped cell coordinate (0..63) of a world coordinate, `inv_cell` cells per metre. Coordinates
// are clamped first (a float-to-int conversion out of range is undefined): beyond +-2^30 cells the
// cells simply stop changing, which only costs locality.
inline uint32_t cell_coordinate(float v, float inv_cell) {
  constexpr float kLimit = 1073741824.0f;  // 2^30
  const float c = std::floor(std::fmin(kLimit, std::fmax(-kLimit, v * inv_cell)));
  const auto i = static_cast<int32_t>(c);
  return static_cast<uint32_t>(i) & ((1u << SpatialOrder::kBitsPerAxis) - 1);
}

}  // namespace

Status SpatialOrderOptions::validate() const {
  if (every_frames < 0)
    return error(ErrorCode::kInvalidArgument,
                 "SpatialOrderOptions.every_frames " + std::to_string(every_frames) + " must be >= 0 (0 = never)");
  if (!(cell_m > 0.0f) || !std::isfinite(cell_m))
    return error(ErrorCode::kInvalidArgument, "SpatialOrderOptions.cell_m must be finite and > 0 metres");
  return Status::success();
}

std::string SpatialOrderOptions::describe() const {
  std::ostringstream s;
  s << "every_frames " << every_frames << " frames  # pool reordered by space this often; 0 = never\n"
    << "cell_m " << cell_m << " m  # edge of the cells surfels are grouped by\n";
  return s.str();
}

std::size_t SpatialOrder::bytes_for(int64_t capacity) {
  const auto n = static_cast<std::size_t>(capacity > 0 ? capacity : 0);
  return n * (sizeof(int32_t) + sizeof(uint32_t)) + static_cast<std::size_t>(kKeys) * sizeof(uint32_t);
}

Result<SpatialOrder> SpatialOrder::create(int64_t capacity, const SpatialOrderOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (capacity < 1)
    return error(ErrorCode::kInvalidArgument, "SpatialOrder: capacity " + std::to_string(capacity) + " must be >= 1");
  SpatialOrder s;
  s.options_ = options;
  s.capacity_ = capacity;
  const auto n = static_cast<std::size_t>(capacity);
  // Value-initialised (zero): the memory is resident from start-up, as the memory plan says.
  s.order_ = std::make_unique<int32_t[]>(n);
  s.key_ = std::make_unique<uint32_t[]>(n);
  s.start_ = std::make_unique<uint32_t[]>(kKeys);
  return s;
}

Status SpatialOrder::reorder(SurfelPool& pool) {
  const int64_t n = pool.size();
  if (n > capacity_)
    return error(ErrorCode::kInvalidArgument, "SpatialOrder: pool of " + std::to_string(n) +
                                                  " surfels exceeds the capacity " + std::to_string(capacity_) +
                                                  " given at create()");
  const float inv_cell = 1.0f / options_.cell_m;
  const float *x = pool.x(), *y = pool.y(), *z = pool.z();
  uint32_t* key = key_.get();
  uint32_t* start = start_.get();
  std::memset(start, 0, static_cast<std::size_t>(kKeys) * sizeof(uint32_t));
  for (int64_t i = 0; i < n; ++i) {
    const uint32_t k = kSpread.v[cell_coordinate(x[i], inv_cell)] | (kSpread.v[cell_coordinate(y[i], inv_cell)] << 1) |
                       (kSpread.v[cell_coordinate(z[i], inv_cell)] << 2);
    key[i] = k;
    ++start[k];
  }
  // Counts to first slots (exclusive prefix sum), then a stable counting sort of the ids by key.
  uint32_t sum = 0;
  for (int k = 0; k < kKeys; ++k) {
    const uint32_t c = start[k];
    start[k] = sum;
    sum += c;
  }
  int32_t* order = order_.get();
  for (int64_t i = 0; i < n; ++i) order[start[key[i]]++] = static_cast<int32_t>(i);
  // The keys are no longer needed: their array is the permutation's scratch.
  pool.permute(order, reinterpret_cast<unsigned char*>(key));
  return Status::success();
}

}  // namespace ef::slam
