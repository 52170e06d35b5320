// The permutohedral lattice (Adams, Baek, Davis, Eurographics 2010): fast approximate Gaussian
// filtering of value vectors attached to points in a d-dimensional feature space, for the dense CRF's
// message passing (Krähenbühl & Koltun, NIPS 2011; semantic/dense_crf.h).
//
// Features are given already divided by the kernel's standard deviations, so the filter approximates
//   out_i = sum_j exp(-|f_i - f_j|^2 / 2) * v_j          (j over every point, i included)
// Three steps:
//   splat  each point's feature vector is lifted onto the hyperplane H = {x in R^(d+1): sum x = 0}
//          (scaled so that the lattice spacing matches a unit standard deviation), the enclosing
//          simplex of the lattice A*_d is found (nearest remainder-0 point, then the ordering of the
//          residuals), and the point's values are added to its d+1 vertices with barycentric weights;
//   blur   along each of the d+1 lattice directions in turn, [1 2 1] / 4 between a vertex and its
//          two neighbours (a neighbour that no point touched does not exist and counts as zero);
//   slice  each point reads back the barycentric interpolation of its d+1 vertices' blurred values.
// The sliced values are those of a normalised blur; gaussian_scale() converts them to the units of
// the unnormalised Gaussian sum above ((2 pi)^(d/2) over the feature-space volume per lattice vertex).
// The approximation is tested against a brute-force filter in tests/semantic/test_dense_crf.cpp.
// Accuracy: the lattice only holds vertices some point touched, so the blur loses what it sends to
// the others. On points sampling a 2-d surface in the 6-d feature space (a surfel map) that loss is a
// nearly constant factor (output 0.67 x the Gaussian sums, and within 7% rms of them after one scale
// factor); on points spread through all 6 dimensions it is 0.33 x, 21% rms after one factor.
// DenseCrf measures the factor on sample surfels each run (DenseCrfOptions::calibration_samples).
//
// Splat, blur and slice move 16-float rows through the kernels' crf_rows family (kernels/crf_rows.h,
// dispatched to the best SIMD variant; every variant gives the scalar reference's bits).
//
// Construction happens once per set of features (begin, add for every point, finish): vertex keys
// (d int16 coordinates) are hashed (open addressing, linear probing, load factor <= 0.5, slots of
// vertex index and full hash), each point keeps its d+1 vertex
// indices and uint16 weights, each vertex keeps its two neighbours along every direction. Filtering
// afterwards moves values only and never touches the hash.
//
// Memory (all allocated by create(), nothing later):
//   per point   kBytesPerPoint = 7 vertex indices (uint32, 28) + 7 weights (uint16, 14) + the
//               self weight (float, 4) = 46 bytes
//   per vertex  kBytesPerVertex = 16 float values (64) + 2 x 7 neighbour indices (uint32, 56) = 120
//               bytes (one extra all-zero row stands for "no neighbour")
//   scratch     borrowed from the caller, kScratchBytesPerVertex = 64 bytes per vertex (see
//               scratch_floats()): the hash table (at most 32 bytes per vertex) and keys (12) while
//               building, the splat target and blur ping-pong buffer while filtering. It holds
//               nothing between calls: lattices may share one when they filter one at a time.
// Threads: not synchronised; one lattice per thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>

#include "core/result.h"

namespace ef::semantic {

// 64-byte aligned arrays of trivial types (a 16-float value row is one cache line), zero-filled:
// touching every page at start-up makes the CRF's memory resident when the run starts, as the
// memory plan says, rather than at its first run mid-mission.
struct AlignedDelete {
  void operator()(void* p) const { ::operator delete(p, std::align_val_t(64)); }
};
template <class T>
using AlignedArray = std::unique_ptr<T[], AlignedDelete>;
template <class T>
AlignedArray<T> make_aligned_array(std::size_t n) {
  const std::size_t bytes = (n > 0 ? n : 1) * sizeof(T);
  void* p = ::operator new(bytes, std::align_val_t(64));
  std::memset(p, 0, bytes);
  return AlignedArray<T>(static_cast<T*>(p));
}

class PermutohedralLattice {
 public:
  static constexpr int kDims = 6;                   // feature dimensions d
  static constexpr int kSimplex = kDims + 1;        // vertices per point, and lattice directions
  static constexpr int kValues = 16;                // floats per value vector (14 classes + 2 pad)
  static constexpr float kWeightOne = 65535.0f;     // a stored weight of 65535 is barycentric 1
  static constexpr std::size_t kBytesPerPoint = kSimplex * (sizeof(uint32_t) + sizeof(uint16_t)) + sizeof(float);
  static constexpr std::size_t kBytesPerVertex = kValues * sizeof(float) + 2 * kSimplex * sizeof(uint32_t);
  static constexpr std::size_t kScratchBytesPerVertex = kValues * sizeof(float);
  // Largest |key coordinate| (lattice units): keys are int16. Features whose lattice point lies
  // beyond it are refused with kOutOfRange (for the CRF at theta_alpha 0.05 m: positions about 200 m
  // from the map's centre along a diagonal, 320 m along an axis).
  static constexpr int kMaxKey = 32000;

  // An empty lattice (no capacity); create() makes a usable one.
  PermutohedralLattice() = default;
  // max_points >= 1 and max_vertices >= kSimplex, both at most 2^31 / kSimplex.
  static Result<PermutohedralLattice> create(int64_t max_points, int64_t max_vertices);
  // Floats of scratch a lattice of max_vertices needs (at least (max_vertices + 1) * kValues).
  static std::size_t scratch_floats(int64_t max_vertices);
  // Bytes create() allocates.
  std::size_t bytes() const;
  // What create(max_points, max_vertices) allocates (points, vertices and one spare value row).
  static std::size_t bytes_for(int64_t max_points, int64_t max_vertices) {
    return std::size_t(max_points) * kBytesPerPoint + std::size_t(max_vertices) * kBytesPerVertex +
           kValues * sizeof(float);
  }

  // --- construction ---------------------------------------------------------------------------
  enum class AddResult {
    kAdded,       // the point and its simplex are in the lattice
    kFull,        // its simplex needs more new vertices than max_vertices leaves: left out (weights 0)
    kOutOfRange,  // a non-finite feature or a key beyond kMaxKey: left out (weights 0)
  };
  // Starts a new lattice (forgets the previous one). scratch: scratch_floats(max_vertices) floats,
  // 64-byte aligned, used until finish().
  void begin(float* scratch);
  // Adds the next point (index = points() before the call) with kDims features f (divided by the
  // kernel's standard deviations). At most max_points points.
  AddResult add(const float* f);
  // Links every vertex to its neighbours along each direction; after this the lattice can filter.
  void finish();
  // Removes point i's contribution (weights 0): for points another kernel's lattice had to leave out.
  void exclude(int64_t i);

  int64_t points() const { return points_; }
  int64_t vertices() const { return vertices_; }
  int64_t max_points() const { return max_points_; }
  int64_t max_vertices() const { return max_vertices_; }
  bool included(int64_t i) const { return self_[i] >= 0; }

  // --- filtering ------------------------------------------------------------------------------
  // Zeroes the splat buffer (scratch rows 0..vertices()) and returns it.
  float* begin_splat(float* scratch) const;
  // Adds point i's value vector, times its weights, to the splat buffer.
  void splat(int64_t i, const float* v, float* splat_buffer) const { splat(i, i + 1, v, splat_buffer); }
  // The same for points begin..end-1 in order, value vectors v[(i - begin) x kValues ...].
  void splat(int64_t begin, int64_t end, const float* v, float* splat_buffer) const;
  // The same for a value vector of uint16 (the CRF's Q in units of 1/65535).
  void splat(int64_t i, const uint16_t* v, float* splat_buffer) const;
  // Blurs the splat buffer along every direction; the result lands in values() (the scratch is
  // overwritten).
  void blur(float* scratch);
  // Point i's interpolated blurred values (raw: times gaussian_scale() for Gaussian-sum units).
  void slice(int64_t i, float* out) const { slice(i, i + 1, out); }
  // The same for points begin..end-1 into (end - begin) x kValues floats of out.
  void slice(int64_t begin, int64_t end, float* out) const;
  // Raw slice(splat(v)) x gaussian_scale() ~ sum_j exp(-|f_i - f_j|^2 / 2) v_j.
  float gaussian_scale() const { return gaussian_scale_; }
  // The part of point i's raw slice that comes from its own splat, per unit of its value, assuming
  // every lattice point on the blur's paths inside its simplex exists (exact for dense maps, an
  // over-estimate where the lattice is sparse). Raw units; -1 for a left-out point.
  float self_weight(int64_t i) const { return self_[i]; }

  // Whole filter: out_i ~ sum_j exp(-|f_i - f_j|^2 / 2) in_j (self included), in and out points()
  // x kValues floats (may not alias). For tests and tools.
  void filter(const float* in, float* out, float* scratch);

  const float* values() const { return values_.get(); }
  const uint32_t* point_vertices() const { return offsets_.get(); }
  const uint16_t* point_weights() const { return weights_.get(); }

 private:
  uint32_t find_or_insert(const int16_t* key, bool insert);
  uint32_t find(const int16_t* key) const;

  int64_t max_points_ = 0, max_vertices_ = 0;
  int64_t points_ = 0, vertices_ = 0;
  uint32_t table_mask_ = 0;
  float gaussian_scale_ = 0;
  float elevate_scale_[kDims] = {};
  float self_table_[kSimplex] = {};   // blur response between simplex vertices k and k + m
  AlignedArray<uint32_t> offsets_;    // max_points x kSimplex
  AlignedArray<uint16_t> weights_;    // max_points x kSimplex
  AlignedArray<float> self_;          // max_points
  AlignedArray<float> values_;        // (max_vertices + 1) x kValues
  AlignedArray<uint32_t> neighbours_; // kSimplex directions x vertices x 2 (minus, plus)
  // Build state in the borrowed scratch.
  uint32_t* table_ = nullptr;
  int16_t* keys_ = nullptr;
  // The previous point's simplex (key and vertex per remainder), when every entry is valid.
  int16_t recent_keys_[kSimplex][kDims] = {};
  uint32_t recent_vertex_[kSimplex] = {};
  bool recent_valid_ = false;
};

}  // namespace ef::semantic
