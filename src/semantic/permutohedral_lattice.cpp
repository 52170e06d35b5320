#include "semantic/permutohedral_lattice.h"

#include <cmath>
#include <cstring>
#include <string>

#include "kernels/crf_rows.h"

namespace ef::semantic {

namespace {
constexpr int D = PermutohedralLattice::kDims;
constexpr int D1 = PermutohedralLattice::kSimplex;
constexpr int V = PermutohedralLattice::kValues;
constexpr uint32_t kEmpty = 0xFFFFFFFFu;
constexpr int64_t kMaxCount = (int64_t(1) << 31) / D1;

uint64_t table_size_for(int64_t max_vertices) {
  uint64_t size = 16;
  while (size < uint64_t(max_vertices) * 2) size *= 2;  // load factor <= 0.5
  return size;
}

uint32_t hash_key(const int16_t* key) {
  uint32_t h = 0x811C9DC5u;
  for (int i = 0; i < D; ++i) h = (h ^ uint32_t(uint16_t(key[i]))) * 0x01000193u;
  return h ^ (h >> 15);
}

bool keys_equal(const int16_t* a, const int16_t* b) {
  for (int i = 0; i < D; ++i)
    if (a[i] != b[i]) return false;
  return true;
}
}  // namespace

Result<PermutohedralLattice> PermutohedralLattice::create(int64_t max_points, int64_t max_vertices) {
  if (max_points < 1 || max_points > kMaxCount || max_vertices < D1 || max_vertices > kMaxCount)
    return error(ErrorCode::kInvalidArgument,
                 "permutohedral lattice: max_points " + std::to_string(max_points) + " and max_vertices " +
                     std::to_string(max_vertices) + " must be in 1.." + std::to_string(kMaxCount) + " and " +
                     std::to_string(D1) + ".." + std::to_string(kMaxCount));
  PermutohedralLattice l;
  l.max_points_ = max_points;
  l.max_vertices_ = max_vertices;
  const auto np = std::size_t(max_points), nv = std::size_t(max_vertices);
  l.offsets_ = make_aligned_array<uint32_t>(np * D1);
  l.weights_ = make_aligned_array<uint16_t>(np * D1);
  l.self_ = make_aligned_array<float>(np);
  l.values_ = make_aligned_array<float>((nv + 1) * V);
  l.neighbours_ = make_aligned_array<uint32_t>(nv * D1 * 2);
  std::memset(l.values_.get(), 0, (nv + 1) * V * sizeof(float));

  // Lifting onto H (Adams et al. section 3.1): feature k enters the elevated coordinates through the
  // column (1 x (k+1), -(k+1), 0 ...), of norm sqrt((k+1)(k+2)); dividing by that norm and multiplying
  // by s = (d+1) sqrt(2/3) makes the lift s times an isometry, with s chosen so that the [1 2 1]
  // blur of the d+1 directions (plus splat and slice) spreads like a unit-variance Gaussian.
  const double s = double(D1) * std::sqrt(2.0 / 3.0);
  for (int k = 0; k < D; ++k) l.elevate_scale_[k] = float(s / std::sqrt(double(k + 1) * double(k + 2)));
  // Volume per lattice vertex: A*_d points (all coordinates congruent mod d+1) have covolume
  // sqrt(d+1) (d+1)^(d-1) in H, the lift scales volumes by s^d. A smooth density rho of points splats
  // rho x that volume onto each vertex; the Gaussian sum is rho (2 pi)^(d/2).
  const double volume = std::sqrt(double(D1)) * std::pow(double(D1), D - 1) / std::pow(s, D);
  l.gaussian_scale_ =
      float(std::pow(2.0 * 3.14159265358979323846, D / 2.0) / volume / (double(kWeightOne) * double(kWeightOne)));
  // Blur response between two vertices of one simplex that differ by m directions: the sequential
  // [1 2 1]/4 passes reach it by stepping along those m directions (1/4 each, 1/2 for the others),
  // or along the other d+1-m directions the opposite way (their sum is the same lattice vector);
  // m = 0: staying put, or stepping along all d+1 directions either way.
  const double base = std::pow(0.5, D1);
  l.self_table_[0] = float(base * (1.0 + 2.0 * base));
  for (int m = 1; m < D1; ++m) l.self_table_[m] = float(base * (std::pow(0.5, m) + std::pow(0.5, D1 - m)));
  return l;
}

std::size_t PermutohedralLattice::scratch_floats(int64_t max_vertices) {
  const std::size_t rows = (std::size_t(max_vertices) + 1) * V;
  const std::size_t keys = (std::size_t(max_vertices) * D * sizeof(int16_t) + 3) / 4;
  const std::size_t build = 2 * table_size_for(max_vertices) + keys;
  return rows > build ? rows : build;
}

std::size_t PermutohedralLattice::bytes() const { return bytes_for(max_points_, max_vertices_); }

void PermutohedralLattice::begin(float* scratch) {
  points_ = 0;
  vertices_ = 0;
  recent_valid_ = false;
  const uint64_t size = table_size_for(max_vertices_);
  table_mask_ = uint32_t(size - 1);
  table_ = reinterpret_cast<uint32_t*>(scratch);
  keys_ = reinterpret_cast<int16_t*>(table_ + 2 * size);
  std::memset(table_, 0xFF, 2 * size * sizeof(uint32_t));
}

// Slots are (vertex, hash) pairs: a probe reads the key only when the whole hash matches.
uint32_t PermutohedralLattice::find(const int16_t* key) const {
  const uint32_t h = hash_key(key);
  for (uint32_t slot = h & table_mask_;; slot = (slot + 1) & table_mask_) {
    const uint32_t v = table_[2 * slot];
    if (v == kEmpty || (table_[2 * slot + 1] == h && keys_equal(keys_ + std::size_t(v) * D, key))) return v;
  }
}

uint32_t PermutohedralLattice::find_or_insert(const int16_t* key, bool insert) {
  const uint32_t h = hash_key(key);
  uint32_t slot = h & table_mask_;
  for (;; slot = (slot + 1) & table_mask_) {
    const uint32_t v = table_[2 * slot];
    if (v == kEmpty) break;
    if (table_[2 * slot + 1] == h && keys_equal(keys_ + std::size_t(v) * D, key)) return v;
  }
  if (!insert) return kEmpty;
  const auto v = uint32_t(vertices_++);
  std::memcpy(keys_ + std::size_t(v) * D, key, D * sizeof(int16_t));
  table_[2 * slot] = v;
  table_[2 * slot + 1] = h;
  return v;
}

PermutohedralLattice::AddResult PermutohedralLattice::add(const float* f) {
  const int64_t i = points_++;
  uint32_t* off = offsets_.get() + i * D1;
  uint16_t* w = weights_.get() + i * D1;
  auto leave_out = [&](AddResult why) {
    for (int k = 0; k < D1; ++k) off[k] = uint32_t(max_vertices_), w[k] = 0;  // the zero row
    self_[i] = -1;
    return why;
  };

  // Lift onto H.
  float elevated[D1];
  float sum_above = 0;
  for (int k = D; k >= 1; --k) {
    const float cf = f[k - 1] * elevate_scale_[k - 1];
    elevated[k] = sum_above - float(k) * cf;
    sum_above += cf;
  }
  elevated[0] = sum_above;
  for (int k = 0; k < D1; ++k)
    if (!(std::fabs(elevated[k]) < float(kMaxKey - 2 * D1))) return leave_out(AddResult::kOutOfRange);

  // The nearest remainder-0 point (coordinates multiples of d+1), then the ordering of the residuals
  // (rank 0 = largest), corrected so that the point lies on H (its coordinates sum to 0).
  int rem0[D1], rank[D1] = {};
  int sum = 0;
  for (int k = 0; k < D1; ++k) {
    const float v = elevated[k] * (1.0f / D1);
    const float up = std::ceil(v) * D1, down = std::floor(v) * D1;
    rem0[k] = int(up - elevated[k] < elevated[k] - down ? up : down);
    sum += rem0[k];
  }
  sum /= D1;
  float residual[D1];
  for (int k = 0; k < D1; ++k) residual[k] = elevated[k] - float(rem0[k]);
  for (int a = 0; a < D1; ++a)
    for (int b = a + 1; b < D1; ++b) ++rank[residual[a] < residual[b] ? a : b];
  if (sum > 0) {
    for (int k = 0; k < D1; ++k) {
      if (rank[k] >= D1 - sum) {
        rem0[k] -= D1;
        rank[k] += sum - D1;
      } else {
        rank[k] += sum;
      }
    }
  } else if (sum < 0) {
    for (int k = 0; k < D1; ++k) {
      if (rank[k] < -sum) {
        rem0[k] += D1;
        rank[k] += D1 + sum;
      } else {
        rank[k] += sum;
      }
    }
  }

  // Barycentric weights (Adams et al. section 3.2).
  float bary[D1 + 1] = {};
  for (int k = 0; k < D1; ++k) {
    const float t = (elevated[k] - float(rem0[k])) * (1.0f / D1);
    bary[D - rank[k]] += t;
    bary[D1 - rank[k]] -= t;
  }
  bary[0] += 1.0f + bary[D1];

  // The simplex's vertices: vertex r adds r to the coordinates of rank <= d - r, r - (d+1) to the
  // others. Keys keep the first d coordinates (the last is minus their sum).
  int16_t keys[D1][D];
  for (int r = 0; r < D1; ++r)
    for (int k = 0; k < D; ++k) keys[r][k] = int16_t(rem0[k] + (rank[k] <= D - r ? r : r - D1));

  if (max_vertices_ - vertices_ < D1) {  // nearly full: insert only when the whole simplex fits
    recent_valid_ = false;
    int64_t missing = 0;
    for (int r = 0; r < D1; ++r) missing += find(keys[r]) == kEmpty ? 1 : 0;
    if (missing > max_vertices_ - vertices_) return leave_out(AddResult::kFull);
  }
  for (int r = 0; r < D1; ++r) {
    // Neighbouring points (the CRF adds them in spatial order) often share vertices with the point
    // before: reuse its lookup.
    if (recent_valid_ && keys_equal(recent_keys_[r], keys[r])) {
      off[r] = recent_vertex_[r];
    } else {
      off[r] = find_or_insert(keys[r], true);
      std::memcpy(recent_keys_[r], keys[r], sizeof(keys[r]));
      recent_vertex_[r] = off[r];
    }
    const float q = std::round(bary[r] * kWeightOne);
    w[r] = uint16_t(q < 0 ? 0.0f : (q > kWeightOne ? kWeightOne : q));
  }
  recent_valid_ = true;
  float self = 0;
  for (int a = 0; a < D1; ++a)
    for (int b = 0; b < D1; ++b) self += float(w[a]) * float(w[b]) * self_table_[a > b ? a - b : b - a];
  self_[i] = self;
  return AddResult::kAdded;
}

void PermutohedralLattice::finish() {
  const auto zero_row = uint32_t(vertices_);
  // Offsets of left-out points named the row max_vertices_; point them at the zero row.
  for (int64_t i = 0; i < points_; ++i)
    if (self_[i] < 0)
      for (int k = 0; k < D1; ++k) offsets_[std::size_t(i * D1 + k)] = zero_row;
  std::memset(values_.get() + std::size_t(vertices_) * V, 0, V * sizeof(float));
  for (int64_t v = 0; v < vertices_; ++v) {
    const int16_t* key = keys_ + std::size_t(v) * D;
    for (int j = 0; j < D1; ++j) {
      // Direction j moves coordinate j by +d and every other one by -1 (j = d: only the implicit
      // last coordinate gains d).
      int16_t minus[D], plus[D];
      for (int k = 0; k < D; ++k) {
        const int step = k == j ? D : -1;
        minus[k] = int16_t(key[k] - step);
        plus[k] = int16_t(key[k] + step);
      }
      const uint32_t m = find(minus), p = find(plus);
      uint32_t* n = neighbours_.get() + (std::size_t(j) * std::size_t(vertices_) + std::size_t(v)) * 2;
      n[0] = m == kEmpty ? zero_row : m;
      n[1] = p == kEmpty ? zero_row : p;
    }
  }
  table_ = nullptr;
  keys_ = nullptr;
}

void PermutohedralLattice::exclude(int64_t i) {
  for (int k = 0; k < D1; ++k) {
    offsets_[std::size_t(i * D1 + k)] = uint32_t(vertices_);
    weights_[std::size_t(i * D1 + k)] = 0;
  }
  self_[i] = -1;
}

void PermutohedralLattice::splat(int64_t begin, int64_t end, const float* v, float* splat_buffer) const {
  kernels::crf_splat_rows(splat_buffer, offsets_.get() + begin * D1, weights_.get() + begin * D1,
                          std::size_t(end - begin), v);
}

void PermutohedralLattice::slice(int64_t begin, int64_t end, float* out) const {
  kernels::crf_slice_rows(values_.get(), offsets_.get() + begin * D1, weights_.get() + begin * D1,
                          std::size_t(end - begin), out);
}

void PermutohedralLattice::splat(int64_t i, const uint16_t* v, float* splat_buffer) const {
  alignas(64) float value[V];
  for (int c = 0; c < V; ++c) value[c] = float(v[c]);
  splat(i, value, splat_buffer);
}

float* PermutohedralLattice::begin_splat(float* scratch) const {
  std::memset(scratch, 0, (std::size_t(vertices_) + 1) * V * sizeof(float));
  return scratch;
}

void PermutohedralLattice::blur(float* scratch) {
  // d+1 = 7 passes ping-pong scratch -> values -> scratch ... -> values. Row vertices_ is zero in
  // both buffers and never written.
  float* in = scratch;
  float* out = values_.get();
  const auto nv = std::size_t(vertices_);
  for (int j = 0; j < D1; ++j) {
    kernels::crf_blur_rows(in, out, neighbours_.get() + std::size_t(j) * nv * 2, 0, nv);
    float* t = in;
    in = out;
    out = t;
  }
  static_assert(D1 % 2 == 1, "an odd number of passes ends in values_");
}

void PermutohedralLattice::filter(const float* in, float* out, float* scratch) {
  float* buffer = begin_splat(scratch);
  splat(0, points_, in, buffer);
  blur(scratch);
  slice(0, points_, out);
  for (int64_t i = 0; i < points_; ++i) {
    for (int c = 0; c < V; ++c) out[i * V + c] *= gaussian_scale_;
  }
}

}  // namespace ef::semantic
