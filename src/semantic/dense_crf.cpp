#include "semantic/dense_crf.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>

#include "semantic/label_store.h"

namespace ef::semantic {

namespace {
using Lattice = PermutohedralLattice;
constexpr int kV = Lattice::kValues;
constexpr int64_t kMaxCapacity = 100'000'000 / Lattice::kSimplex;
constexpr float kQOne = 65535.0f;  // Q is stored in units of 1/65535
constexpr int kDensityLane = 14;    // a padding lane of Q: splats 1 for the scale calibration
// Surfels per block of the mean-field loop (the kernels slice and splat a block at a time; three
// blocks of rows, 12 KiB, live on the stack).
constexpr int64_t kBlock = 64;
// Prefetch distance (slots) for the label store: slots are in spatial order, the store in pool order,
// so each surfel's 16 cost bytes are a random read of a store far larger than the caches.
constexpr int64_t kLabelPrefetch = 16;

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// e^x for x in [-87, 0] (callers clamp), relative error below 2e-7: x = n ln 2 + r with |r| <= ln2/2,
// e^r by its Taylor polynomial to r^6, 2^n put into the exponent bits. Plain float and int loops over
// the 16 lanes, which vectorise.
inline void exp_nonpositive16(const float* __restrict x, float* __restrict out) {
  alignas(64) int32_t bits[kV];
  alignas(64) float scale[kV];
  for (int c = 0; c < kV; ++c) {
    const float t = x[c] * 1.44269504f;
    const int32_t n = int32_t(t - 0.5f);  // t <= 0: truncation of t - 0.5 rounds to nearest
    const float r = (x[c] - float(n) * 0.693145752f) - float(n) * 1.42860677e-6f;
    float p = 1.0f / 720.0f;
    p = p * r + 1.0f / 120.0f;
    p = p * r + 1.0f / 24.0f;
    p = p * r + 1.0f / 6.0f;
    p = p * r + 0.5f;
    p = p * r + 1.0f;
    p = p * r + 1.0f;
    out[c] = p;
    bits[c] = (n + 127) << 23;
  }
  std::memcpy(scale, bits, sizeof(scale));
  for (int c = 0; c < kV; ++c) out[c] *= scale[c];
}

// z: kV floats, the first kLabelClasses are -psi_u + message (nats); writes the normalised
// distribution into q (padding lanes 0).
inline void softmax_classes(float* __restrict z, float* __restrict q) {
  z[14] = z[15] = -1e30f;
  float mx = z[0];
  for (int c = 1; c < kV; ++c) mx = z[c] > mx ? z[c] : mx;
  alignas(64) float x[kV], e[kV];
  for (int c = 0; c < kV; ++c) {
    const float d = z[c] - mx;
    x[c] = d < -87.0f ? -87.0f : d;
  }
  exp_nonpositive16(x, e);
  e[14] = e[15] = 0.0f;
  float sum = 0;
  for (int c = 0; c < kV; ++c) sum += e[c];
  const float inv = 1.0f / sum;
  for (int c = 0; c < kV; ++c) q[c] = e[c] * inv;
}

// Q in units of 1/65535; the density lane holds 1 (65535) so that every filter also sums the kernel.
inline void store_q(const float* q, uint16_t* out) {
  for (int c = 0; c < kV; ++c) out[c] = uint16_t(q[c] * kQOne + 0.5f);
  out[kDensityLane] = uint16_t(kQOne);
}
}  // namespace

int64_t DenseCrfOptions::lattice_vertices() const {
  if (max_lattice_vertices > 0) return max_lattice_vertices;
  const int64_t derived = (capacity * 3 + 9) / 10;
  return derived < Lattice::kSimplex ? Lattice::kSimplex : derived;
}

const opt::Table<DenseCrfOptions>& DenseCrfOptions::table() {
  static const opt::Table<DenseCrfOptions> t = {
      {"iterations", "crf_iterations", "--crf-iterations", &DenseCrfOptions::iterations, "", opt::between(1, 100),
       "mean-field iterations per CRF run (the paper's 10)"},
      {"min_confidence", "crf_min_confidence", "", &DenseCrfOptions::min_confidence, "fusion weight",
       opt::between(0, 1e6), "surfels below take no part in the CRF (their labels as fused); 0 = every surfel"},
  };
  return t;
}

Status DenseCrfOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "dense crf"));
  auto positive = [](float v) { return std::isfinite(v) && v > 0; };
  auto non_negative = [](float v) { return std::isfinite(v) && v >= 0; };
  if (!positive(bilateral_theta_position_m) || !positive(bilateral_theta_color) ||
      !positive(spatial_theta_position_m) || !positive(spatial_theta_normal))
    return error(ErrorCode::kInvalidArgument,
                 "dense crf: every kernel standard deviation (theta) must be finite and > 0 (" + describe() + ")");
  if (!non_negative(bilateral_weight) || !non_negative(spatial_weight))
    return error(ErrorCode::kInvalidArgument,
                 "dense crf: kernel weights must be finite and >= 0 (" + describe() + ")");
  if (capacity < 1 || capacity > kMaxCapacity)
    return error(ErrorCode::kInvalidArgument, "dense crf: capacity " + std::to_string(capacity) +
                                                  " must be in 1.." + std::to_string(kMaxCapacity) + " surfels");
  if (calibration_samples < 0 || calibration_samples > 4096)
    return error(ErrorCode::kInvalidArgument, "dense crf: calibration_samples " +
                                                  std::to_string(calibration_samples) + " must be in 0..4096");
  if (max_lattice_vertices != 0 && (max_lattice_vertices < Lattice::kSimplex || max_lattice_vertices > kMaxCapacity))
    return error(ErrorCode::kInvalidArgument, "dense crf: max_lattice_vertices " +
                                                  std::to_string(max_lattice_vertices) + " must be 0 (derived) or in " +
                                                  std::to_string(Lattice::kSimplex) + ".." +
                                                  std::to_string(kMaxCapacity));
  return Status::success();
}

std::string DenseCrfOptions::describe() const {
  std::ostringstream s;
  s << "bilateral theta " << bilateral_theta_position_m << " m / colour " << bilateral_theta_color << ", weight "
    << bilateral_weight << "; spatial theta " << spatial_theta_position_m << " m / normal " << spatial_theta_normal
    << ", weight " << spatial_weight << "; " << iterations << " iterations; surfels with confidence >= "
    << min_confidence << "; capacity " << capacity
    << " surfels, " << lattice_vertices() << " lattice vertices per kernel"
    << (max_lattice_vertices == 0 ? " (derived)" : "") << "; " << calibration_samples << " calibration samples";
  return s.str();
}

Result<DenseCrf> DenseCrf::create(const DenseCrfOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  DenseCrf crf;
  crf.options_ = options;
  const int64_t max_vertices = options.lattice_vertices();
  EF_ASSIGN_OR_RETURN(crf.bilateral_, Lattice::create(options.capacity, max_vertices));
  EF_ASSIGN_OR_RETURN(crf.spatial_, Lattice::create(options.capacity, max_vertices));
  crf.scratch_floats_ = Lattice::scratch_floats(max_vertices);
  for (auto& buffer : crf.scratch_) buffer = make_aligned_array<float>(crf.scratch_floats_);
  crf.q_ = make_aligned_array<uint16_t>(std::size_t(options.capacity) * kV);
  crf.order_ = make_aligned_array<uint32_t>(std::size_t(options.capacity));
  // The memory plan sizes this object by bytes_for(): the two must never disagree.
  if (crf.bytes() != bytes_for(options))
    return error(ErrorCode::kInternal, "dense crf: allocated " + std::to_string(crf.bytes()) + " bytes, bytes_for() says " +
                                           std::to_string(bytes_for(options)));
  return crf;
}

std::size_t DenseCrf::bytes_for(const DenseCrfOptions& options) {
  const int64_t vertices = options.lattice_vertices();
  return 2 * Lattice::bytes_for(options.capacity, vertices) + 2 * Lattice::scratch_floats(vertices) * sizeof(float) +
         std::size_t(options.capacity) * (kV * sizeof(uint16_t) + sizeof(uint32_t));
}

std::size_t DenseCrf::bytes() const {
  return bilateral_.bytes() + spatial_.bytes() + 2 * scratch_floats_ * sizeof(float) +
         std::size_t(options_.capacity) * (kV * sizeof(uint16_t) + sizeof(uint32_t));
}

Result<DenseCrfStats> DenseCrf::run(slam::SurfelPool& pool) {
  const auto t_start = std::chrono::steady_clock::now();
  const slam::SurfelPool& read = pool;  // const columns (slam/surfel_pool.h: block bounds stay current)
  const int64_t size = pool.size();
  DenseCrfStats stats;
  stats.surfels = size;
  // The nodes: surfels at or above min_confidence, and of those, when there are more than the
  // capacity, the ones seen most recently (whole frames: every node seen at most max_age frames
  // before the newest is one).
  const float* confidence = read.confidence();
  const int32_t* last_seen = read.last_seen();
  const float min_confidence = options_.min_confidence;
  const auto confident = [&](int64_t i) { return !(confidence[i] < min_confidence); };
  int64_t n = 0;
  int32_t newest = INT32_MIN;
  for (int64_t i = 0; i < size; ++i) {
    if (!confident(i)) continue;
    ++n;
    newest = std::max(newest, last_seen[i]);
  }
  stats.surfels_unconfident = size - n;
  int64_t max_age = INT64_MAX;
  if (n > options_.capacity) {
    // Ages (frames before the newest) in bins of one frame up to kAges - 2, the rest in the last;
    // the largest age whose nodes and younger ones fit.
    constexpr int kAges = 4096;
    uint32_t histogram[kAges] = {};
    for (int64_t i = 0; i < size; ++i)
      if (confident(i)) ++histogram[std::min<int64_t>(int64_t(newest) - last_seen[i], kAges - 1)];
    int64_t kept = 0;
    max_age = -1;
    for (int a = 0; a < kAges - 1 && kept + histogram[a] <= options_.capacity; ++a) {
      kept += histogram[a];
      max_age = a;
    }
    stats.surfels_beyond_capacity = n - kept;
    n = kept;
  }
  const auto node = [&](int64_t i) { return confident(i) && int64_t(newest) - last_seen[i] <= max_age; };
  if (n == 0) {
    stats.total_ms = ms_since(t_start);
    return stats;
  }

  const float *px = read.x(), *py = read.y(), *pz = read.z();
  const float *nx = read.nx(), *ny = read.ny(), *nz = read.nz();
  const uint32_t* color = read.color();
  // The map's centre (middle of the nodes' bounding box) keeps lattice keys small.
  int64_t first = 0;
  while (!node(first)) ++first;
  float lo[3] = {px[first], py[first], pz[first]}, hi[3] = {px[first], py[first], pz[first]};
  for (int64_t i = 0; i < size; ++i) {
    if (!node(i)) continue;
    const float p[3] = {px[i], py[i], pz[i]};
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]) || !std::isfinite(nx[i]) ||
        !std::isfinite(ny[i]) || !std::isfinite(nz[i]))
      return error(ErrorCode::kOutOfRange,
                   "dense crf: surfel " + std::to_string(i) + " has a non-finite position or normal");
    for (int a = 0; a < 3; ++a) {
      lo[a] = p[a] < lo[a] ? p[a] : lo[a];
      hi[a] = p[a] > hi[a] ? p[a] : hi[a];
    }
  }
  const float centre[3] = {0.5f * (lo[0] + hi[0]), 0.5f * (lo[1] + hi[1]), 0.5f * (lo[2] + hi[2])};

  // Processing order: surfels sorted by cells of 2 theta_alpha (x fastest, then y, z; pool order
  // within a cell; coarser cells when the grid would not fit the scratch), by counting sort. The
  // CRF's per-surfel arrays are kept in this order ("slots"), so neighbouring surfels touch
  // neighbouring lattice vertices: the lattice rows stay in cache. A SLAM pool's order follows
  // time, not space.
  float* scratch = scratch_[0].get();
  uint32_t* order = order_.get();
  {
    const double extent[3] = {double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2]};
    double cell = 2.0 * double(std::max(options_.bilateral_theta_position_m, options_.spatial_theta_position_m));
    int64_t dims[3] = {1, 1, 1};
    const auto room = int64_t(scratch_floats_) - 1;
    auto grid_cells = [&](double side) {
      double cells = 1;
      for (int a = 0; a < 3; ++a) cells *= std::floor(extent[a] / side) + 1;
      return cells;
    };
    while (grid_cells(cell) > double(room)) cell *= 2;
    for (int a = 0; a < 3; ++a) dims[a] = int64_t(extent[a] / cell) + 1;
    const double inv = 1.0 / cell;
    auto axis = [&](float p, float low, int a) {
      const double t = (double(p) - double(low)) * inv;
      return t <= 0 ? int64_t(0) : (t >= double(dims[a] - 1) ? dims[a] - 1 : int64_t(t));
    };
    auto cell_of = [&](int64_t i) {
      return std::size_t((axis(pz[i], lo[2], 2) * dims[1] + axis(py[i], lo[1], 1)) * dims[0] + axis(px[i], lo[0], 0));
    };
    uint32_t* counts = reinterpret_cast<uint32_t*>(scratch);
    const auto cells = std::size_t(dims[0] * dims[1] * dims[2]);
    std::memset(counts, 0, (cells + 1) * sizeof(uint32_t));
    for (int64_t i = 0; i < size; ++i)
      if (node(i)) ++counts[cell_of(i) + 1];
    for (std::size_t c = 1; c <= cells; ++c) counts[c] += counts[c - 1];
    for (int64_t i = 0; i < size; ++i)
      if (node(i)) order[counts[cell_of(i)]++] = uint32_t(i);
  }

  // Lattices, once per run (features do not change across iterations); point k = surfel order[k].
  auto build = [&](Lattice& lattice, float inv_pos, float inv_other, bool colour) -> Status {
    lattice.begin(scratch);
    for (int64_t k = 0; k < n; ++k) {
      const int64_t i = order[k];
      float f[Lattice::kDims] = {(px[i] - centre[0]) * inv_pos, (py[i] - centre[1]) * inv_pos,
                                 (pz[i] - centre[2]) * inv_pos};
      if (colour) {
        f[3] = float(slam::unpack_r(color[i])) * inv_other;
        f[4] = float(slam::unpack_g(color[i])) * inv_other;
        f[5] = float(slam::unpack_b(color[i])) * inv_other;
      } else {
        f[3] = nx[i] * inv_other;
        f[4] = ny[i] * inv_other;
        f[5] = nz[i] * inv_other;
      }
      if (lattice.add(f) == Lattice::AddResult::kOutOfRange)
        return error(ErrorCode::kOutOfRange, "dense crf: surfel " + std::to_string(i) + " at (" +
                                                 std::to_string(px[i]) + ", " + std::to_string(py[i]) + ", " +
                                                 std::to_string(pz[i]) +
                                                 ") m is too far from the map's centre for the lattice keys");
    }
    lattice.finish();
    return Status::success();
  };
  EF_RETURN_IF_ERROR(build(bilateral_, 1.0f / options_.bilateral_theta_position_m,
                           1.0f / options_.bilateral_theta_color, true));
  EF_RETURN_IF_ERROR(
      build(spatial_, 1.0f / options_.spatial_theta_position_m, 1.0f / options_.spatial_theta_normal, false));
  // A surfel either lattice left out takes no part at all.
  for (int64_t i = 0; i < n; ++i) {
    if (bilateral_.included(i) && spatial_.included(i)) continue;
    bilateral_.exclude(i);
    spatial_.exclude(i);
    ++stats.surfels_left_out;
  }
  stats.bilateral_vertices = bilateral_.vertices();
  stats.spatial_vertices = spatial_.vertices();
  stats.build_ms = ms_since(t_start);

  const auto t_iterate = std::chrono::steady_clock::now();
  uint8_t* labels = pool.labels();
  uint16_t* q16 = q_.get();
  // Initialisation: Q = softmax(-psi_u), psi_u(l) = cost_l * kLabelCostStep nats (+ a constant per surfel).
  for (int64_t i = 0; i < n; ++i) {
    if (i + kLabelPrefetch < n) __builtin_prefetch(labels + std::size_t(order[i + kLabelPrefetch]) * kLabelBytes);
    alignas(64) float z[kV], q[kV];
    const uint8_t* cost = labels + std::size_t(order[i]) * kLabelBytes;
    for (int c = 0; c < kLabelClasses; ++c) z[c] = -float(cost[c]) * kLabelCostStep;
    softmax_classes(z, q);
    store_q(q, q16 + i * kV);
  }

  // Filtered values are sums of splatted Q (units 1/65535) x weights (65535 = 1) x weights.
  const float w1 = options_.bilateral_weight, w2 = options_.spatial_weight;
  float g1 = bilateral_.gaussian_scale() / kQOne, g2 = spatial_.gaussian_scale() / kQOne;
  const float s1 = bilateral_.gaussian_scale(), s2 = spatial_.gaussian_scale();
  // fn(r0, r1) for runs of at most kBlock consecutive slots whose surfel takes part (a surfel either
  // lattice left out is excluded from both), in slot order.
  auto for_each_included_run = [&](int64_t begin, int64_t end, auto&& fn) {
    for (int64_t r0 = begin; r0 < end;) {
      if (!bilateral_.included(r0)) {
        ++r0;
        continue;
      }
      int64_t r1 = r0 + 1;
      while (r1 < end && r1 - r0 < kBlock && bilateral_.included(r1)) ++r1;
      fn(r0, r1);
      r0 = r1;
    }
  };
  // Each kernel has its own splat buffer, so one pass over the surfels slices iteration t's filters
  // and splats iteration t+1's Q; then both buffers are blurred into the lattices' values.
  float* splat1 = bilateral_.begin_splat(scratch_[0].get());
  float* splat2 = spatial_.begin_splat(scratch_[1].get());
  for_each_included_run(0, n, [&](int64_t r0, int64_t r1) {
    alignas(64) float stored[kBlock * kV];
    for (int64_t i = r0; i < r1; ++i)
      for (int c = 0; c < kV; ++c) stored[(i - r0) * kV + c] = float(q16[i * kV + c]);
    bilateral_.splat(r0, r1, stored, splat1);
    spatial_.splat(r0, r1, stored, splat2);
  });
  bilateral_.blur(splat1);
  spatial_.blur(splat2);
  for (int it = 0; it < options_.iterations; ++it) {
    if (it == 0 && options_.calibration_samples > 0) {
      // Scale calibration: the sparse lattice loses the mass its blur sends to vertices no surfel
      // touched, by a nearly constant factor on a surface (corrections of 1.3-1.4 on the test maps
      // and on bench_crf's map). The exact kernel sums sum_j k(f_s, f_j) of a stride of sample
      // surfels against the lattice's (the density lane) give each kernel's factor. Self weights
      // stay in the analytic scale (their paths lose about the same share).
      const int64_t samples = std::min<int64_t>(options_.calibration_samples, n);
      double exact1 = 0, exact2 = 0, lattice1 = 0, lattice2 = 0;
      const float ip1 = 1.0f / options_.bilateral_theta_position_m, ic = 1.0f / options_.bilateral_theta_color;
      const float ip2 = 1.0f / options_.spatial_theta_position_m, in = 1.0f / options_.spatial_theta_normal;
      for (int64_t k = 0; k < samples; ++k) {
        const int64_t slot = (k * n) / samples, s = order[slot];
        if (!bilateral_.included(slot)) continue;
        alignas(64) float a[kV], b[kV];
        bilateral_.slice(slot, a);
        spatial_.slice(slot, b);
        lattice1 += double(a[kDensityLane]) * double(g1);
        lattice2 += double(b[kDensityLane]) * double(g2);
        const float cr = float(slam::unpack_r(color[s])), cg = float(slam::unpack_g(color[s])),
                    cb = float(slam::unpack_b(color[s]));
        for (int64_t kj = 0; kj < n; ++kj) {
          // Pool order (sequential reads) when every surfel takes part, else slot order.
          const bool all = stats.surfels_left_out == 0 && n == size;
          const int64_t j = all ? kj : int64_t(order[kj]);
          if (!all && !bilateral_.included(kj)) continue;
          const float dx = px[j] - px[s], dy = py[j] - py[s], dz = pz[j] - pz[s];
          const float p2 = dx * dx + dy * dy + dz * dz;
          const float d1 = p2 * ip1 * ip1, d2 = p2 * ip2 * ip2;
          if (d1 > 50.0f && d2 > 50.0f) continue;  // both kernels below e^-25
          const float r = float(slam::unpack_r(color[j])) - cr, g = float(slam::unpack_g(color[j])) - cg,
                      bb = float(slam::unpack_b(color[j])) - cb;
          const float ex = nx[j] - nx[s], ey = ny[j] - ny[s], ez = nz[j] - nz[s];
          exact1 += std::exp(-0.5 * double(d1 + (r * r + g * g + bb * bb) * ic * ic));
          exact2 += std::exp(-0.5 * double(d2 + (ex * ex + ey * ey + ez * ez) * in * in));
        }
      }
      if (lattice1 > 0 && exact1 > 0) stats.bilateral_scale_correction = float(exact1 / lattice1);
      if (lattice2 > 0 && exact2 > 0) stats.spatial_scale_correction = float(exact2 / lattice2);
      g1 *= stats.bilateral_scale_correction;
      g2 *= stats.spatial_scale_correction;
    }
    const bool last = it + 1 == options_.iterations;
    if (!last) {
      bilateral_.begin_splat(splat1);
      spatial_.begin_splat(splat2);
    }
    // Blocks of consecutive surfels that take part: both kernels sliced for the block, each surfel's
    // update, then the block's new Q splatted (slices read the lattices' values, splats write the
    // splat buffers, so the block order gives the per-surfel order's bits).
    for_each_included_run(0, n, [&](int64_t r0, int64_t r1) {
      alignas(64) float a[kBlock * kV], b[kBlock * kV], stored[kBlock * kV];
      bilateral_.slice(r0, r1, a);
      spatial_.slice(r0, r1, b);
      for (int64_t i = r0; i < r1; ++i) {
        if (i + kLabelPrefetch < n) __builtin_prefetch(labels + std::size_t(order[i + kLabelPrefetch]) * kLabelBytes);
        alignas(64) float z[kV], q[kV];
        const float* ai = a + (i - r0) * kV;
        const float* bi = b + (i - r0) * kV;
        // The surfel's own share of each filter, in the same units, is taken out (s' != s).
        const float self1 = s1 * bilateral_.self_weight(i), self2 = s2 * spatial_.self_weight(i);
        const uint16_t* qi = q16 + i * kV;
        uint8_t* cost = labels + std::size_t(order[i]) * kLabelBytes;
        for (int c = 0; c < kV; ++c) {
          const float own = float(qi[c]) * (1.0f / kQOne);
          const float message = w1 * (g1 * ai[c] - self1 * own) + w2 * (g2 * bi[c] - self2 * own);
          z[c] = message - float(cost[c]) * kLabelCostStep;
        }
        softmax_classes(z, q);
        if (last) {
          encode_labels(q, cost);
        } else {
          // Splat exactly the stored (quantised) Q, which the next iteration's self term uses.
          uint16_t* next = q16 + i * kV;
          store_q(q, next);
          for (int c = 0; c < kV; ++c) stored[(i - r0) * kV + c] = float(next[c]);
        }
      }
      if (!last) {
        bilateral_.splat(r0, r1, stored, splat1);
        spatial_.splat(r0, r1, stored, splat2);
      }
    });
    if (!last) {
      bilateral_.blur(splat1);
      spatial_.blur(splat2);
    }
  }
  stats.surfels_updated = n - stats.surfels_left_out;  // the nodes the lattices held
  stats.iterations = options_.iterations;
  stats.iterate_ms = ms_since(t_iterate);
  stats.total_ms = ms_since(t_start);
  return stats;
}

}  // namespace ef::semantic
