// The dense CRF over the surfel map (SemanticFusion, McCormac et al. ICRA 2017, section IV-D,
// equations 2-6; inference of Krähenbühl & Koltun, NIPS 2011).
//
// Every surfel is a node; the energy is E(x) = sum_s psi_u(x_s) + sum_{s<s'} psi_p(x_s, x_s')
// (eq. 2) with the unary psi_u(l) = -ln P(L_s = l) of the surfel's fused distribution (eq. 3, read
// from the label store: cost_l * kLabelCostStep (1/8) nats, semantic/label_store.h) and a Potts pairwise term
// mu(l, l') = [l != l'] times two Gaussian kernels (eqs. 4-6):
//   bilateral  w1 exp(-|p - p'|^2 / 2 theta_a^2 - |c - c'|^2 / 2 theta_b^2)   (position, RGB)
//   spatial    w2 exp(-|p - p'|^2 / 2 theta_a^2 - |n - n'|^2 / 2 theta_g^2)   (position, normal)
// Mean field: Q_s = softmax(-psi_u) initially, then each iteration
//   m_s(l) = sum_k w_k (sum_{s' != s} k_k(f_s, f_s') Q_s'(l))                    (message)
//   Q_s(l) = exp(-psi_u(l) + m_s(l)) / Z_s    (Potts: -compat(m) = +m up to a per-surfel constant)
// Each kernel's sum over s' is one permutohedral-lattice filter (semantic/permutohedral_lattice.h)
// in a 6-d feature space; the surfel's own contribution is subtracted with the lattice's self
// weight. At the end every updated distribution is written back with encode_labels, so the CRF
// updates the map's probabilities incrementally, as the paper does (it is not a final labelling).
//
// Classes: all 14 store classes, 0 ("unknown") included, take part like the others. The store
// keeps no separate "unobserved" state (a new surfel is uniform over all 14), and a surfel the CNN
// called unknown should keep that belief unless its neighbours disagree; leaving class 0 out would
// need a second renormalisation rule. Uniform (never-observed) surfels take part too: their flat
// unary lets their neighbours decide, which is the CRF's purpose.
//
// Memory (create() allocates everything; run() allocates nothing):
//   per surfel of capacity   kBytesPerSurfel = 2 lattices x 46 (PermutohedralLattice::kBytesPerPoint:
//                            7 vertex indices uint32, 7 weights uint16, 1 float) + Q as 16 uint16 (32)
//                            + the processing order (uint32, 4) = 128 bytes
//   per lattice vertex       kBytesPerVertex = 2 lattices x (120: 16 float values, 14 neighbour
//                            indices; + 64: a splat buffer row, which also holds the hash table and
//                            keys while building) = 368 bytes
//   total                    capacity x 128 + max_lattice_vertices x 368; DenseCrf::bytes(). With the
//                            derived vertex limit (0.3 per surfel): 238 bytes per surfel of capacity,
//                            238 MB for 1,000,000 surfels, 119 MB for 500,000.
//   stack                    the iterations take 64 surfels at a time: three blocks of 64 x 16 floats
//                            (12 KiB: both kernels' slices and the new Q to splat)
// Splat, blur and slice are the kernels' crf_rows family (kernels/crf_rows.h): the best SIMD variant
// for the CPU, each giving the scalar reference's bits, so the results do not depend on the variant.
// Lattice full (more vertices than max_lattice_vertices in one kernel's lattice): the surfels whose
// simplex no longer fits are left out of the CRF (no messages to or from them, their labels
// untouched) and counted in DenseCrfStats::surfels_left_out; the run still succeeds.
//
// Threads: run() on one thread; one DenseCrf per thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/options.h"
#include "core/result.h"
#include "semantic/permutohedral_lattice.h"
#include "slam/surfel_pool.h"

namespace ef::semantic {

struct DenseCrfOptions {
  // Bilateral (appearance) kernel k1, eq. 5: position standard deviation theta_alpha (metres,
  // > 0, default 0.05), colour standard deviation theta_beta (8-bit sRGB units per channel, > 0,
  // default 20), weight w1 (dimensionless, >= 0, default 10).
  float bilateral_theta_position_m = 0.05f;
  float bilateral_theta_color = 20.0f;
  float bilateral_weight = 10.0f;
  // Spatial (smoothness) kernel k2, eq. 6: position standard deviation theta_alpha (metres, > 0,
  // default 0.05), normal standard deviation theta_gamma (in unit-normal components, > 0, default
  // 0.1; the paper calls it 0.1 rad: for small angles |n - n'| ~ the angle in radians), weight w2
  // (dimensionless, >= 0, default 3).
  float spatial_theta_position_m = 0.05f;
  float spatial_theta_normal = 0.1f;
  float spatial_weight = 3.0f;
  // Mean-field iterations per run (1..100: its table). Default 10 (the paper).
  int iterations = 10;
  // Surfels with confidence below this (the pool's accumulated fusion weight, >= 0) are not nodes of
  // the CRF: no messages to or from them, their labels untouched (DenseCrfStats::surfels_unconfident).
  // Default 10, the map's stable threshold (FusionOptions::stable_confidence's default): the CRF
  // covers the surface tracking trusts, not the fringe of single views and noise that fusion has not
  // confirmed (and may still remove). On the real 7-Scenes map (371k surfels, 277k stable) 10
  // iterations take 0.82 s instead of 1.15 s and fit in fewer lattice vertices (docs/results.md,
  // with its effect on Table I). 0 = every surfel.
  float min_confidence = 10.0f;
  // Most surfels one run handles as nodes (>= 1, at most 100,000,000 / 7). When the pool holds more
  // at or above min_confidence, the nodes are those seen most recently (every one seen within the
  // last A frames, A the largest that fits), the rest keep their labels and are counted
  // (DenseCrfStats::surfels_beyond_capacity): a map larger than the memory allows is still refined
  // where the camera is. Default 1,000,000 (the default pool). kBytesPerSurfel each.
  int64_t capacity = 1'000'000;
  // Most vertices of each kernel's lattice (>= 7); 0 = derived: 3/10 of capacity (rounded up, at
  // least 7). A simplex has 7 vertices but neighbouring surfels share them: bench_crf's 500k-surfel
  // map sampled from noise-free synthetic frames needs 0.21 vertices per surfel in either lattice,
  // so the default leaves 40% headroom. Noisier maps need more (raw single Kinect-like frames: 0.46
  // bilateral, 2.4 spatial, from their noisy normals); beyond the limit surfels are left out (see the
  // file comment) and counted, never a crash.
  int64_t max_lattice_vertices = 0;
  // Surfels (0..4096; 0 = off) whose exact kernel sums calibrate each lattice's scale once per run
  // (see DenseCrfStats::*_scale_correction): a stride over the map, each compared with every surfel
  // within 7 theta_alpha, O(samples x surfels) cheap distance tests. Default 32.
  int calibration_samples = 32;

  // The vertex limit in force (max_lattice_vertices, or the derived default).
  int64_t lattice_vertices() const;
  // The keys `run` offers (section crf): iterations, min_confidence.
  static const opt::Table<DenseCrfOptions>& table();
  Status validate() const;
  std::string describe() const;
};

struct DenseCrfStats {
  int64_t surfels = 0;            // surfels in the pool when run() started
  int64_t surfels_updated = 0;    // surfels whose distribution was rewritten
  int64_t surfels_left_out = 0;   // surfels not updated because a lattice was full
  int64_t surfels_unconfident = 0;  // surfels below DenseCrfOptions::min_confidence: no nodes
  int64_t surfels_beyond_capacity = 0;  // confident surfels seen longest ago beyond the capacity: no nodes
  int64_t bilateral_vertices = 0; // lattice vertices of the bilateral kernel
  int64_t spatial_vertices = 0;   // lattice vertices of the spatial kernel
  int iterations = 0;             // mean-field iterations run
  // Factors applied to each lattice's analytic Gaussian scale (1 = none): the exact kernel sums of
  // the calibration samples over the lattice's. The lattice drops the blur's mass at vertices no
  // surfel touched, a nearly uniform loss on a surface map (about 1.5x on tests/semantic's surface).
  float bilateral_scale_correction = 1.0f;
  float spatial_scale_correction = 1.0f;
  double build_ms = 0;            // wall milliseconds: features and both lattices
  double iterate_ms = 0;          // wall milliseconds: initialisation, iterations, write-back
  double total_ms = 0;            // wall milliseconds of run()
};

class DenseCrf {
 public:
  static constexpr std::size_t kBytesPerSurfel =
      2 * PermutohedralLattice::kBytesPerPoint + PermutohedralLattice::kValues * sizeof(uint16_t) + sizeof(uint32_t);
  static constexpr std::size_t kBytesPerVertex =
      2 * (PermutohedralLattice::kBytesPerVertex + PermutohedralLattice::kScratchBytesPerVertex);

  // Validates the options and allocates every buffer (lattices, scratch, Q) for options.capacity.
  static Result<DenseCrf> create(const DenseCrfOptions& options = {});

  // Runs options().iterations mean-field iterations over every surfel of `pool` and writes the
  // resulting distributions into its label store. Allocates nothing.
  // Errors (the pool untouched): kResourceExhausted when pool.size() > capacity; kOutOfRange when a
  // surfel has a non-finite position, normal or a position too far from the map's centre for the
  // lattice keys (about 200 m along a diagonal at the default theta_alpha).
  Result<DenseCrfStats> run(slam::SurfelPool& pool);

  const DenseCrfOptions& options() const { return options_; }
  // Bytes create() allocated.
  std::size_t bytes() const;
  // Bytes create(options) allocates: two lattices, their two scratch buffers, Q and the order.
  static std::size_t bytes_for(const DenseCrfOptions& options);

 private:
  DenseCrf() = default;

  DenseCrfOptions options_;
  PermutohedralLattice bilateral_, spatial_;
  AlignedArray<float> scratch_[2];  // per kernel: splat buffer (and hash while building)
  AlignedArray<uint16_t> q_;     // capacity x 16: Q in units of 1/65535, slot order
  AlignedArray<uint32_t> order_; // capacity: slot -> surfel id (spatial processing order)
  std::size_t scratch_floats_ = 0;
};

}  // namespace ef::semantic
