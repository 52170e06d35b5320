// The map's deformation graph for loop closure: embedded deformation (Sumner, Schmid, Pauly,
// "Embedded deformation for shape manipulation", SIGGRAPH 2007) as ElasticFusion uses it (Whelan et
// al., RSS 2015 section 5 and IJRR 2016 section 5; defaults in ../shared/reference/algorithms.md).
//
// Nodes are sampled from the surfels (one per `surfels_per_node`, at most max_nodes, ElasticFusion 1
// per ~5000 and 1024) and ordered by the surfels' time. Each node j has a position g_j and an
// affine transform (A_j, t_j), 12 unknowns, identity at first. Node j is connected to the next
// `neighbours` nodes in time (ElasticFusion's k = 4): the graph follows the camera's path, so a
// loop's end can bend back to its start through every node between them.
//
// A surfel's time is the frame that last fused it (last_seen), not ElasticFusion's creation time
// (init_time): its position carries the pose error of the frames that fused it last, and with our
// default association (every surfel in view, mapping.associate_active_only false) a revisit fuses
// into old surfels, which then belong to the surface the camera sees now. By creation time they were
// pinned while the new surfels beside them moved, and the map tore: on the two-lap synthetic loop
// with 3% depth bias, closures then lost 33 frames and left 92 cm ATE (20 cm without closure); by
// last fusion, 21 cm and none lost. On 7-Scenes with ElasticFusion's association the corrected
// trajectory is 3.07 cm by last fusion against 3.64 cm by creation (docs/results.md).
//
// A point v with time tau (a surfel's last_seen, a camera's frame) is moved by the `neighbours`
// nearest nodes among the 2k + 1 nodes nearest to tau in time:
//   phi(v) = sum_j w_j (A_j (v - g_j) + g_j + t_j),  w_j = (1 - |v - g_j| / d_max)^2, normalised,
// d_max the distance to the (k+1)-th nearest of those nodes; a normal n moves to
// normalise(sum_j w_j A_j^-T n).
//
// The energy, minimised by Gauss-Newton (ElasticFusion: up to 3 iterations):
//   w_rot sum_j Rot(A_j)                                  A_j stays a rotation (Sumner's six terms:
//                                                         its columns unit length and orthogonal)
//   w_reg sum_j sum_{l ~ j} |A_j (g_l - g_j) + g_j + t_j - (g_l + t_l)|^2   neighbours agree
//   w_con sum_c |phi(v_c) - q_c|^2                        constraints: v_c should go to q_c (a loop
//                                                         closure's surface correspondences; q_c = v_c
//                                                         pins a point)
// Weights 1, 10, 100 (ElasticFusion).
//
// The linear system of each step is banded: with the nodes in time order, every term couples nodes at
// most 2k apart (the time windows above), so its matrix has a half bandwidth of 12 (2k + 1) - 1
// unknowns. It is solved by our own banded Cholesky factorisation in a buffer allocated at create()
// (n x (b + 1) doubles: 10.6 MB for 1024 nodes and k = 4; O(n b^2) per step, about 0.15 G
// multiply-adds). Why not Eigen's SimplicialLDLT: it allocates its ordering, elimination tree and
// factor on every factorisation, and the per-frame path must not (tests check our factorisation
// against it). A closure whose constraints are still far from met after the optimisation would tear
// the map: optimise() reports the RMS of the constraint residuals, and the caller rejects it above
// its threshold.
//
// Memory: create() allocates everything (nodes, constraints, the band); build(), add_constraint(),
// optimise() and the apply functions allocate nothing. Threads: not synchronised.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "core/options.h"
#include "core/result.h"
#include "core/se3.h"

namespace ef::slam {

class SurfelPool;

struct DeformationGraphOptions {
  int32_t max_nodes = 1024;         // nodes at most (ElasticFusion 1024), 4..16384
  int32_t surfels_per_node = 5000;  // one node per this many surfels (ElasticFusion ~5000), >= 1
  int32_t neighbours = 4;           // k: graph edges per node and nodes per point (ElasticFusion 4), 1..8
  int32_t max_constraints = 4096;   // constraints a closure may add, 1..1000000
  int32_t iterations = 3;           // Gauss-Newton steps (ElasticFusion up to 3), 1..20
  double weight_rotation = 1.0, weight_regularisation = 10.0, weight_constraint = 100.0;  // > 0

  // The keys `run` offers (section mapping, each named deformation_*).
  static const opt::Table<DeformationGraphOptions>& table();
  Status validate() const;
  // These options with max_nodes cut to what a pool of `capacity` surfels can ever need (one node
  // per surfels_per_node, at least neighbours + 2): what a SLAM allocates (1,000,000 surfels: 200
  // nodes, 2.3 MB).
  DeformationGraphOptions for_pool(int64_t capacity) const;
};

struct DeformationResult {
  double rms_before_m = 0;  // RMS of |phi(v_c) - q_c| over the constraints before and after, metres
  double rms_after_m = 0;
  double max_after_m = 0;
  double energy_before = 0, energy_after = 0;  // the weighted energy above
  int iterations = 0;
  double ms = 0;            // wall time of optimise()
};

class DeformationGraph {
 public:
  static Result<DeformationGraph> create(const DeformationGraphOptions& options = {});
  static std::size_t bytes_for(const DeformationGraphOptions& options);
  std::size_t bytes() const { return bytes_for(options_); }

  // Samples the nodes from the pool's surfels (every size / nodes-th surfel), orders them by time
  // and resets every transform to the identity and the constraints to none. Error (kInvalidArgument)
  // when the pool has fewer surfels than neighbours + 2.
  Status build(const SurfelPool& pool);
  // Nodes from explicit positions and times (tests; a map that is not a pool). count <= max_nodes.
  Status build(const Eigen::Vector3f* positions, const int32_t* times, int32_t count);

  // v at time tau should move to q. Returns false (and counts nothing) when the constraint table is
  // full.
  bool add_constraint(const Eigen::Vector3f& v, int32_t tau, const Eigen::Vector3f& q);
  int32_t constraints() const { return constraint_count_; }
  int32_t nodes() const { return node_count_; }

  // Gauss-Newton from the identity (or the current transforms); fills `result`. Error
  // (kInvalidArgument) when the graph was not built, kInternal when the system is not positive definite.
  Status optimise(DeformationResult* result);

  // The deformation applied to a point, a normal and a camera pose at time tau.
  Eigen::Vector3f apply_point(const Eigen::Vector3f& v, int32_t tau) const;
  // Camera to world: its centre moves as a point, its rotation by the nearest-rotation of the
  // weighted node transforms.
  SE3 apply_pose(const SE3& T_world_cam, int32_t tau) const;
  // Every surfel's position and normal (by its last_seen); nothing else of a surfel changes (colour,
  // confidence, labels, times stay with it: ids do not move).
  void apply(SurfelPool& pool) const;

  const DeformationGraphOptions& options() const { return options_; }
  Eigen::Vector3d node_position(int32_t j) const { return g_[j]; }
  int32_t node_time(int32_t j) const { return time_[j]; }

  // The banded Cholesky solve used by optimise(), exposed for tests: solves H x = b for the
  // symmetric positive definite H whose lower band (half bandwidth `b`, row i holds H(i, i-b..i) at
  // band[i * (b + 1) + (b - (i - j))]) is given; band is overwritten by the factor. Returns false
  // when H is not positive definite.
  static bool solve_banded(double* band, int n, int b, double* rhs);

 private:
  DeformationGraph() = default;
  // The nodes that move a point at time tau and their weights; returns how many (<= neighbours).
  int influences(const Eigen::Vector3d& v, int32_t tau, int32_t* ids, double* weights) const;
  // phi(v) of the file comment over the given nodes and weights: the one formula every term and
  // every apply function uses.
  Eigen::Vector3d phi(const Eigen::Vector3d& v, const int32_t* ids, const double* weights, int n) const;
  double energy_and_system(bool build_system);
  void finish_nodes();

  DeformationGraphOptions options_;
  int half_band_ = 0;               // unknowns
  int32_t node_count_ = 0;
  std::unique_ptr<Eigen::Vector3d[]> g_;        // node positions, metres
  std::unique_ptr<int32_t[]> time_;             // node times (sorted)
  std::unique_ptr<Eigen::Matrix3d[]> A_;        // node transforms
  std::unique_ptr<Eigen::Vector3d[]> t_;
  std::unique_ptr<Eigen::Matrix3d[]> normal_A_; // A_j^-T, for normals (finish_nodes)
  std::unique_ptr<int32_t[]> order_;            // scratch for sorting the sampled nodes
  struct Constraint {
    Eigen::Vector3d v, q;
    int32_t n;
    int32_t ids[8];
    double w[8];
  };
  std::unique_ptr<Constraint[]> constraints_;
  int32_t constraint_count_ = 0;
  std::unique_ptr<double[]> band_;   // n x (half_band + 1)
  std::unique_ptr<double[]> rhs_;    // n
};

}  // namespace ef::slam
