#include "slam/deformation_graph.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "core/stopwatch.h"
#include "slam/surfel_pool.h"

namespace ef::slam {

namespace {
constexpr int kMaxNeighbours = 8;
constexpr int kUnknownsPerNode = 12;  // A (row-major 3x3), t
}  // namespace

const opt::Table<DeformationGraphOptions>& DeformationGraphOptions::table() {
  static const opt::Table<DeformationGraphOptions> t = {
      {"deformation_max_nodes", "", "", &DeformationGraphOptions::max_nodes, "nodes", opt::between(4, 16384),
       "loop closure: the deformation graph's nodes at most (ElasticFusion 1024; a pool needs one per "
       "deformation_surfels_per_node), allocated at start-up"},
      {"deformation_surfels_per_node", "", "", &DeformationGraphOptions::surfels_per_node, "surfels",
       opt::at_least(1), "loop closure: one graph node per this many surfels (ElasticFusion about 5000)"},
      {"deformation_neighbours", "", "", &DeformationGraphOptions::neighbours, "nodes", opt::between(1, kMaxNeighbours),
       "loop closure: graph edges per node and nodes that move each surfel (ElasticFusion 4)"},
      {"deformation_max_constraints", "", "", &DeformationGraphOptions::max_constraints, "constraints",
       opt::between(1, 1000000), "loop closure: the most constraints one closure adds, allocated at start-up"},
      {"deformation_iterations", "", "", &DeformationGraphOptions::iterations, "steps", opt::between(1, 20),
       "loop closure: Gauss-Newton steps of a closure's optimisation (ElasticFusion up to 3)"},
      {"deformation_weight_rotation", "", "", &DeformationGraphOptions::weight_rotation, "", opt::above(0),
       "loop closure: weight of the nodes' rotation term (ElasticFusion 1)"},
      {"deformation_weight_regularisation", "", "", &DeformationGraphOptions::weight_regularisation, "",
       opt::above(0), "loop closure: weight of the smoothness between neighbouring nodes (ElasticFusion 10)"},
      {"deformation_weight_constraint", "", "", &DeformationGraphOptions::weight_constraint, "", opt::above(0),
       "loop closure: weight of the closure's constraints (ElasticFusion 100)"},
  };
  return t;
}

Status DeformationGraphOptions::validate() const { return opt::check_table(*this, table(), "deformation graph"); }

DeformationGraphOptions DeformationGraphOptions::for_pool(int64_t capacity) const {
  DeformationGraphOptions o = *this;
  const int64_t needed = (capacity + surfels_per_node - 1) / std::max(surfels_per_node, 1);
  o.max_nodes = static_cast<int32_t>(std::clamp<int64_t>(needed, std::max(4, neighbours + 2), max_nodes));
  return o;
}

std::size_t DeformationGraph::bytes_for(const DeformationGraphOptions& o) {
  const std::size_t n = static_cast<std::size_t>(std::max(o.max_nodes, 0));
  const std::size_t unknowns = n * kUnknownsPerNode;
  const std::size_t band = static_cast<std::size_t>(kUnknownsPerNode * (2 * o.neighbours + 1));  // b + 1
  return n * (2 * sizeof(Eigen::Vector3d) + 2 * sizeof(Eigen::Matrix3d) + 2 * sizeof(int32_t)) +
         static_cast<std::size_t>(std::max(o.max_constraints, 0)) * sizeof(Constraint) +
         unknowns * band * sizeof(double) + unknowns * sizeof(double);
}

Result<DeformationGraph> DeformationGraph::create(const DeformationGraphOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  DeformationGraph g;
  g.options_ = options;
  g.half_band_ = kUnknownsPerNode * (2 * options.neighbours + 1) - 1;
  const std::size_t n = static_cast<std::size_t>(options.max_nodes);
  g.g_.reset(new Eigen::Vector3d[n]);
  g.time_.reset(new int32_t[n]());
  g.A_.reset(new Eigen::Matrix3d[n]);
  g.t_.reset(new Eigen::Vector3d[n]);
  g.normal_A_.reset(new Eigen::Matrix3d[n]);
  g.order_.reset(new int32_t[n]());
  g.constraints_.reset(new Constraint[static_cast<std::size_t>(options.max_constraints)]);
  g.band_.reset(new double[n * kUnknownsPerNode * static_cast<std::size_t>(g.half_band_ + 1)]());
  g.rhs_.reset(new double[n * kUnknownsPerNode]());
  return g;
}

Status DeformationGraph::build(const SurfelPool& pool) {
  const int64_t size = pool.size();
  const int k = options_.neighbours;
  if (size < k + 2)
    return error(ErrorCode::kInvalidArgument, "deformation graph: a map of " + std::to_string(size) +
                                                     " surfels is too small for a graph of " +
                                                     std::to_string(k + 2) + " nodes");
  const int64_t wanted = std::clamp<int64_t>(size / options_.surfels_per_node, k + 2, options_.max_nodes);
  const int32_t count = static_cast<int32_t>(std::min<int64_t>(wanted, size));
  // Every size / count-th surfel: the pool is grouped by space (slam/spatial_order.h), so the nodes
  // spread over the map.
  auto sample = [&](int32_t j) { return static_cast<int64_t>(j) * size / count; };
  for (int32_t j = 0; j < count; ++j) order_[j] = j;
  const int32_t* time = pool.last_seen();
  std::sort(order_.get(), order_.get() + count, [&](int32_t a, int32_t b) {
    const int32_t ta = time[sample(a)], tb = time[sample(b)];
    return ta != tb ? ta < tb : a < b;
  });
  for (int32_t j = 0; j < count; ++j) {
    const int64_t id = sample(order_[j]);
    g_[j] = Eigen::Vector3d(pool.x()[id], pool.y()[id], pool.z()[id]);
    time_[j] = time[id];
  }
  node_count_ = count;
  finish_nodes();
  return Status::success();
}

Status DeformationGraph::build(const Eigen::Vector3f* positions, const int32_t* times, int32_t count) {
  if (count < options_.neighbours + 2 || count > options_.max_nodes)
    return error(ErrorCode::kInvalidArgument, "deformation graph: " + std::to_string(count) + " nodes is outside " +
                                                  std::to_string(options_.neighbours + 2) + ".." +
                                                  std::to_string(options_.max_nodes));
  for (int32_t j = 0; j < count; ++j) order_[j] = j;
  std::sort(order_.get(), order_.get() + count,
            [&](int32_t a, int32_t b) { return times[a] != times[b] ? times[a] < times[b] : a < b; });
  for (int32_t j = 0; j < count; ++j) {
    g_[j] = positions[order_[j]].cast<double>();
    time_[j] = times[order_[j]];
  }
  node_count_ = count;
  finish_nodes();
  return Status::success();
}

// Resets the transforms to the identity and drops the constraints.
void DeformationGraph::finish_nodes() {
  for (int32_t j = 0; j < node_count_; ++j) {
    A_[j].setIdentity();
    t_[j].setZero();
    normal_A_[j].setIdentity();
  }
  constraint_count_ = 0;
}

int DeformationGraph::influences(const Eigen::Vector3d& v, int32_t tau, int32_t* ids, double* weights) const {
  const int k = options_.neighbours;
  const int32_t n = node_count_;
  // The node nearest in time, then a window of k on either side.
  int32_t c = static_cast<int32_t>(std::lower_bound(time_.get(), time_.get() + n, tau) - time_.get());
  if (c == n || (c > 0 && tau - time_[c - 1] <= time_[c] - tau)) c = std::max(0, c - 1);
  const int32_t lo = std::max(0, c - k), hi = std::min(n - 1, c + k);
  int32_t cand[2 * kMaxNeighbours + 1];
  double dist[2 * kMaxNeighbours + 1];
  int m = 0;
  for (int32_t j = lo; j <= hi; ++j) {
    cand[m] = j;
    dist[m] = (v - g_[j]).norm();
    ++m;
  }
  if (m == 0) return 0;  // no nodes (not built): the point stays where it is
  // The k + 1 nearest first (selection: m <= 17).
  const int keep = std::min(m, k + 1);
  for (int a = 0; a < keep; ++a) {
    int best = a;
    for (int b = a + 1; b < m; ++b)
      if (dist[b] < dist[best] || (dist[b] == dist[best] && cand[b] < cand[best])) best = b;
    std::swap(dist[a], dist[best]);
    std::swap(cand[a], cand[best]);
  }
  const int used = std::min(k, m);
  const double d_max = keep > used ? dist[used] : dist[used - 1] * 1.0001 + 1e-9;
  double sum = 0;
  for (int a = 0; a < used; ++a) {
    const double r = d_max > 0 ? 1.0 - dist[a] / d_max : 1.0;
    weights[a] = r * r;
    ids[a] = cand[a];
    sum += weights[a];
  }
  for (int a = 0; a < used; ++a) weights[a] = sum > 0 ? weights[a] / sum : 1.0 / used;
  return used;
}

bool DeformationGraph::add_constraint(const Eigen::Vector3f& v, int32_t tau, const Eigen::Vector3f& q) {
  if (constraint_count_ >= options_.max_constraints || node_count_ == 0) return false;
  Constraint& c = constraints_[constraint_count_++];
  c.v = v.cast<double>();
  c.q = q.cast<double>();
  c.n = influences(c.v, tau, c.ids, c.w);
  return true;
}

namespace {

// One residual row r with its Jacobian entries (unknown index, value): adds w J^T J into the lower
// band of H and w J^T r into g.
struct RowAccumulator {
  double* band;
  double* rhs;
  int b;
  void add(const int* idx, const double* val, int m, double r, double w) const {
    for (int p = 0; p < m; ++p) {
      rhs[idx[p]] += w * val[p] * r;
      double* row = band + static_cast<std::size_t>(idx[p]) * (b + 1) + b - idx[p];  // row[j] = H(i, j)
      for (int q = 0; q < m; ++q)
        if (idx[q] <= idx[p]) row[idx[q]] += w * val[p] * val[q];
    }
  }
};

}  // namespace

Eigen::Vector3d DeformationGraph::phi(const Eigen::Vector3d& v, const int32_t* ids, const double* w, int n) const {
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) out += w[i] * (A_[ids[i]] * (v - g_[ids[i]]) + g_[ids[i]] + t_[ids[i]]);
  return out;
}

double DeformationGraph::energy_and_system(bool build_system) {
  const int n_unknowns = node_count_ * kUnknownsPerNode;
  const int b = half_band_;
  if (build_system) {
    std::fill(band_.get(), band_.get() + static_cast<std::size_t>(n_unknowns) * (b + 1), 0.0);
    std::fill(rhs_.get(), rhs_.get() + n_unknowns, 0.0);
  }
  const RowAccumulator acc{band_.get(), rhs_.get(), b};
  double energy = 0;
  int idx[4 * kMaxNeighbours];
  double val[4 * kMaxNeighbours];

  // Rotation: the columns of A_j orthonormal.
  const double w_rot = options_.weight_rotation;
  for (int32_t j = 0; j < node_count_; ++j) {
    const Eigen::Matrix3d& A = A_[j];
    const int base = j * kUnknownsPerNode;
    for (int c1 = 0; c1 < 3; ++c1)
      for (int c2 = c1; c2 < 3; ++c2) {
        const double r = A.col(c1).dot(A.col(c2)) - (c1 == c2 ? 1.0 : 0.0);
        energy += w_rot * r * r;
        if (!build_system) continue;
        int m = 0;
        for (int a = 0; a < 3; ++a) {
          if (c1 == c2) {
            idx[m] = base + 3 * a + c1;
            val[m++] = 2.0 * A(a, c1);
          } else {
            idx[m] = base + 3 * a + c1;
            val[m++] = A(a, c2);
            idx[m] = base + 3 * a + c2;
            val[m++] = A(a, c1);
          }
        }
        acc.add(idx, val, m, r, w_rot);
      }
  }

  // Regularisation: each node and its next k in time, both ways.
  const double w_reg = options_.weight_regularisation;
  for (int32_t j = 0; j < node_count_; ++j)
    for (int32_t l = j + 1; l <= std::min(node_count_ - 1, j + options_.neighbours); ++l)
      for (int dir = 0; dir < 2; ++dir) {
        const int32_t from = dir == 0 ? j : l, to = dir == 0 ? l : j;
        const Eigen::Vector3d d = g_[to] - g_[from];
        const Eigen::Vector3d e = A_[from] * d + g_[from] + t_[from] - g_[to] - t_[to];
        energy += w_reg * e.squaredNorm();
        if (!build_system) continue;
        for (int a = 0; a < 3; ++a) {
          int m = 0;
          for (int c = 0; c < 3; ++c) {
            idx[m] = from * kUnknownsPerNode + 3 * a + c;
            val[m++] = d[c];
          }
          idx[m] = from * kUnknownsPerNode + 9 + a;
          val[m++] = 1.0;
          idx[m] = to * kUnknownsPerNode + 9 + a;
          val[m++] = -1.0;
          acc.add(idx, val, m, e[a], w_reg);
        }
      }

  // Constraints.
  const double w_con = options_.weight_constraint;
  for (int32_t ci = 0; ci < constraint_count_; ++ci) {
    const Constraint& c = constraints_[ci];
    const Eigen::Vector3d e = phi(c.v, c.ids, c.w, c.n) - c.q;
    energy += w_con * e.squaredNorm();
    if (!build_system) continue;
    for (int a = 0; a < 3; ++a) {
      int m = 0;
      for (int i = 0; i < c.n; ++i) {
        const Eigen::Vector3d d = c.v - g_[c.ids[i]];
        for (int col = 0; col < 3; ++col) {
          idx[m] = c.ids[i] * kUnknownsPerNode + 3 * a + col;
          val[m++] = c.w[i] * d[col];
        }
        idx[m] = c.ids[i] * kUnknownsPerNode + 9 + a;
        val[m++] = c.w[i];
      }
      acc.add(idx, val, m, e[a], w_con);
    }
  }
  return energy;
}

bool DeformationGraph::solve_banded(double* band, int n, int b, double* rhs) {
  // L L^T in place. Row i of the band holds columns i-b..i; L(i, j) = Li[j] with Li = band + i (b+1) + b - i.
  const std::size_t stride = static_cast<std::size_t>(b) + 1;
  for (int i = 0; i < n; ++i) {
    double* Li = band + static_cast<std::size_t>(i) * stride + b - i;
    const int j0 = std::max(0, i - b);
    for (int j = j0; j <= i; ++j) {
      const double* Lj = band + static_cast<std::size_t>(j) * stride + b - j;
      double s = Li[j];
      for (int k = j0; k < j; ++k) s -= Li[k] * Lj[k];
      if (j == i) {
        if (!(s > 0) || !std::isfinite(s)) return false;
        Li[i] = std::sqrt(s);
      } else {
        Li[j] = s / Lj[j];
      }
    }
  }
  // L y = rhs, then L^T x = y.
  for (int i = 0; i < n; ++i) {
    const double* Li = band + static_cast<std::size_t>(i) * stride + b - i;
    double s = rhs[i];
    for (int k = std::max(0, i - b); k < i; ++k) s -= Li[k] * rhs[k];
    rhs[i] = s / Li[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = rhs[i];
    for (int k = i + 1; k <= std::min(n - 1, i + b); ++k)
      s -= band[static_cast<std::size_t>(k) * stride + b - k + i] * rhs[k];
    rhs[i] = s / band[static_cast<std::size_t>(i) * stride + b];
  }
  return true;
}

Status DeformationGraph::optimise(DeformationResult* result) {
  const SteadyClock::time_point t0 = SteadyClock::now();
  *result = DeformationResult{};
  if (node_count_ == 0) return error(ErrorCode::kInvalidArgument, "deformation graph: not built");
  auto constraint_rms = [&](double* max_out) {
    double sum = 0, mx = 0;
    for (int32_t ci = 0; ci < constraint_count_; ++ci) {
      const Constraint& c = constraints_[ci];
      const double e = (phi(c.v, c.ids, c.w, c.n) - c.q).norm();
      sum += e * e;
      mx = std::max(mx, e);
    }
    if (max_out) *max_out = mx;
    return constraint_count_ > 0 ? std::sqrt(sum / constraint_count_) : 0.0;
  };
  result->rms_before_m = constraint_rms(nullptr);
  result->energy_before = energy_and_system(false);
  const int n = node_count_ * kUnknownsPerNode;
  for (int it = 0; it < options_.iterations; ++it) {
    energy_and_system(true);
    // A small damping keeps directions no term constrains (a node far from every constraint, all
    // nodes' common translation without constraints) at zero.
    for (int i = 0; i < n; ++i) {
      band_[static_cast<std::size_t>(i) * (half_band_ + 1) + half_band_] += 1e-9;
      rhs_[i] = -rhs_[i];
    }
    if (!solve_banded(band_.get(), n, half_band_, rhs_.get()))
      return error(ErrorCode::kInternal, "deformation graph: the Gauss-Newton system is not positive definite");
    double step = 0;
    for (int32_t j = 0; j < node_count_; ++j) {
      const double* dx = rhs_.get() + j * kUnknownsPerNode;
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c) A_[j](a, c) += dx[3 * a + c];
      t_[j] += Eigen::Vector3d(dx[9], dx[10], dx[11]);
      for (int i = 0; i < kUnknownsPerNode; ++i) step = std::max(step, std::abs(dx[i]));
    }
    ++result->iterations;
    if (step < 1e-7) break;
  }
  for (int32_t j = 0; j < node_count_; ++j) normal_A_[j] = A_[j].inverse().transpose();
  result->energy_after = energy_and_system(false);
  result->rms_after_m = constraint_rms(&result->max_after_m);
  result->ms = ms_since(t0);
  return Status::success();
}

Eigen::Vector3f DeformationGraph::apply_point(const Eigen::Vector3f& vf, int32_t tau) const {
  int32_t ids[kMaxNeighbours];
  double w[kMaxNeighbours];
  const Eigen::Vector3d v = vf.cast<double>();
  const int m = influences(v, tau, ids, w);
  if (m == 0) return vf;
  return phi(v, ids, w, m).cast<float>();
}

SE3 DeformationGraph::apply_pose(const SE3& T, int32_t tau) const {
  int32_t ids[kMaxNeighbours];
  double w[kMaxNeighbours];
  const Eigen::Vector3d c = T.translation();
  const int m = influences(c, tau, ids, w);
  if (m == 0) return T;
  const Eigen::Vector3d centre = phi(c, ids, w, m);
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (int i = 0; i < m; ++i) M += w[i] * A_[ids[i]];
  // The rotation nearest to the blended transform (its polar factor).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) = -U.col(2);
    R = U * svd.matrixV().transpose();
  }
  return SE3(R * T.rotation_matrix(), centre);
}

void DeformationGraph::apply(SurfelPool& pool) const {
  int32_t ids[kMaxNeighbours];
  double w[kMaxNeighbours];
  float *x = pool.x(), *y = pool.y(), *z = pool.z(), *nx = pool.nx(), *ny = pool.ny(), *nz = pool.nz();
  const int32_t* time = pool.last_seen();
  for (int64_t i = 0; i < pool.size(); ++i) {
    const Eigen::Vector3d v(x[i], y[i], z[i]);
    const int m = influences(v, time[i], ids, w);
    if (m == 0) return;  // not built: nothing moves
    const Eigen::Vector3d p = phi(v, ids, w, m);
    const Eigen::Vector3d n0(nx[i], ny[i], nz[i]);
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (int a = 0; a < m; ++a) n += w[a] * (normal_A_[ids[a]] * n0);
    const double len = n.norm();
    if (len > 0) n /= len;
    x[i] = static_cast<float>(p.x());
    y[i] = static_cast<float>(p.y());
    z[i] = static_cast<float>(p.z());
    nx[i] = static_cast<float>(n.x());
    ny[i] = static_cast<float>(n.y());
    nz[i] = static_cast<float>(n.z());
  }
}

}  // namespace ef::slam
