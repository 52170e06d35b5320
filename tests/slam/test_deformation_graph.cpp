// The embedded deformation graph (slam/deformation_graph.h): its banded solver against Eigen's sparse
// Cholesky, a bent path meeting its constraints, a contradiction it cannot meet, the labels and
// everything else of a surfel riding along, no allocation.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "slam/deformation_graph.h"
#include "slam/surfel_pool.h"
#include "support/alloc_counter.h"

namespace ef::slam {
namespace {

TEST(DeformationGraph, BandedCholeskyMatchesEigenSparseCholesky) {
  constexpr int n = 150, b = 23;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // A banded SPD matrix: B^T B + n I for a banded B.
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = std::max(0, i - b / 2); j <= std::min(n - 1, i + b / 2); ++j) B(i, j) = u(rng);
  Eigen::MatrixXd H = B.transpose() * B + 0.5 * Eigen::MatrixXd::Identity(n, n);
  Eigen::VectorXd rhs(n);
  for (int i = 0; i < n; ++i) rhs[i] = u(rng);
  std::vector<double> band(static_cast<std::size_t>(n) * (b + 1), 0.0);
  for (int i = 0; i < n; ++i)
    for (int j = std::max(0, i - b); j <= i; ++j) {
      ASSERT_LE(i - j, b);
      band[static_cast<std::size_t>(i) * (b + 1) + b - (i - j)] = H(i, j);
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < i - b; ++j) ASSERT_EQ(H(i, j), 0.0) << "not banded";
  std::vector<double> x(rhs.data(), rhs.data() + n);
  ASSERT_TRUE(DeformationGraph::solve_banded(band.data(), n, b, x.data()));
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(H.sparseView());
  ASSERT_EQ(ldlt.info(), Eigen::Success);
  const Eigen::VectorXd ref = ldlt.solve(rhs);
  for (int i = 0; i < n; ++i) EXPECT_NEAR(x[i], ref[i], 1e-9 * (1 + std::abs(ref[i]))) << i;
  // Not positive definite: refused.
  std::vector<double> neg(static_cast<std::size_t>(n) * (b + 1), 0.0);
  for (int i = 0; i < n; ++i) neg[static_cast<std::size_t>(i) * (b + 1) + b] = i == 40 ? -1.0 : 1.0;
  std::vector<double> y(n, 1.0);
  EXPECT_FALSE(DeformationGraph::solve_banded(neg.data(), n, b, y.data()));
}

// A camera path along x (3 m over 300 frames) and the surface it saw, one node every 10 frames.
struct Path {
  std::vector<Eigen::Vector3f> nodes;
  std::vector<int32_t> times;
  Path() {
    for (int f = 0; f < 300; f += 10) {
      nodes.emplace_back(0.01f * f, 0.3f * std::sin(0.02f * f), 1.0f);
      times.push_back(f);
    }
  }
  static Eigen::Vector3f point(int f) { return {0.01f * f, 0.3f * std::sin(0.02f * f), 1.0f}; }
};

DeformationGraph make_graph(DeformationGraphOptions o = {}) {
  auto g = DeformationGraph::create(o);
  EXPECT_TRUE(g.ok()) << to_string(g.error());
  return std::move(*g);
}

TEST(DeformationGraph, ALoopsEndMovesToItsConstraintsAndTheStartStaysPinned) {
  DeformationGraph g = make_graph();
  const Path path;
  ASSERT_TRUE(g.build(path.nodes.data(), path.times.data(), static_cast<int32_t>(path.nodes.size())).ok());
  const Eigen::Vector3f shift(0.0f, 0.10f, -0.05f);
  for (int f = 0; f < 60; f += 3) ASSERT_TRUE(g.add_constraint(Path::point(f), f, Path::point(f)));  // pinned
  for (int f = 260; f < 300; f += 3) ASSERT_TRUE(g.add_constraint(Path::point(f), f, Path::point(f) + shift));
  DeformationResult r;
  ASSERT_TRUE(g.optimise(&r).ok());
  EXPECT_GT(r.rms_before_m, 0.05);
  EXPECT_LT(r.rms_after_m, 0.005) << "after " << r.iterations << " steps";
  EXPECT_LT(r.energy_after, r.energy_before);
  // The start stays, the end moves by the shift, the middle in between.
  EXPECT_LT((g.apply_point(Path::point(20), 20) - Path::point(20)).norm(), 0.003f);
  EXPECT_LT((g.apply_point(Path::point(280), 280) - (Path::point(280) + shift)).norm(), 0.005f);
  const float middle = (g.apply_point(Path::point(160), 160) - Path::point(160)).norm();
  EXPECT_GT(middle, 0.01f);
  EXPECT_LT(middle, shift.norm());
  // A camera at the end moves with its surface; its rotation stays a rotation.
  const SE3 cam(Eigen::Matrix3d::Identity(), Path::point(285).cast<double>() - Eigen::Vector3d(0, 0, 1));
  const SE3 moved = g.apply_pose(cam, 285);
  EXPECT_LT((moved.translation() - cam.translation() - shift.cast<double>()).norm(), 0.01);
  EXPECT_NEAR(moved.rotation().norm(), 1.0, 1e-12);
}

TEST(DeformationGraph, ContradictoryConstraintsAreLeftFarFromMet) {
  DeformationGraph g = make_graph();
  const Path path;
  ASSERT_TRUE(g.build(path.nodes.data(), path.times.data(), static_cast<int32_t>(path.nodes.size())).ok());
  // The same points asked to go to two places 1 m apart: no deformation meets both; a caller
  // rejects the closure by the residual it reports.
  for (int f = 100; f < 140; f += 4) {
    g.add_constraint(Path::point(f), f, Path::point(f));
    g.add_constraint(Path::point(f), f, Path::point(f) + Eigen::Vector3f(1, 0, 0));
  }
  DeformationResult r;
  ASSERT_TRUE(g.optimise(&r).ok());
  EXPECT_GT(r.rms_after_m, 0.4);
}

TEST(DeformationGraph, TheConstraintTableIsBounded) {
  DeformationGraphOptions o;
  o.max_constraints = 5;
  DeformationGraph g = make_graph(o);
  const Path path;
  ASSERT_TRUE(g.build(path.nodes.data(), path.times.data(), static_cast<int32_t>(path.nodes.size())).ok());
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(g.add_constraint(Path::point(i), i, Path::point(i)));
  EXPECT_FALSE(g.add_constraint(Path::point(6), 6, Path::point(6)));
  EXPECT_EQ(g.constraints(), 5);
  EXPECT_FALSE(DeformationGraph::create(DeformationGraphOptions{2}).ok());  // max_nodes < 4
  // Before build(): nothing moves, and optimise() says why.
  DeformationGraph empty = make_graph();
  EXPECT_EQ(empty.apply_point(Eigen::Vector3f(1, 2, 3), 5), Eigen::Vector3f(1, 2, 3));
  EXPECT_EQ(empty.apply_pose(SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 0, 0)), 5).translation(),
            Eigen::Vector3d(1, 0, 0));
  DeformationResult r;
  EXPECT_FALSE(empty.optimise(&r).ok());
}

// A labelled map is deformed: every surfel keeps its label distribution, colour, confidence,
// radius and times (its id does not change); only positions and normals move.
TEST(DeformationGraph, LabelsRideAlongWithTheirSurfels) {
  SurfelPoolOptions po;
  po.capacity = 3000;
  auto pool_or = SurfelPool::create(po);
  ASSERT_TRUE(pool_or.ok());
  SurfelPool& pool = *pool_or;
  std::mt19937 rng(11);
  for (int i = 0; i < 3000; ++i) {
    const int f = i / 10;  // frame 0..299 along the path
    const Eigen::Vector3f p = Path::point(f) + Eigen::Vector3f(0, 0.001f * (i % 10), 0);
    const int64_t id = pool.append(p.x(), p.y(), p.z(), 0, 0, -1, 0.004f, 1.0f + (i % 7),
                                   pack_rgb(uint8_t(i), uint8_t(i >> 3), 7), f);
    ASSERT_EQ(id, i);
    for (int k = 0; k < SurfelPool::kLabelBytesPerSurfel; ++k) pool.labels()[i * SurfelPool::kLabelBytesPerSurfel + k] = uint8_t(rng());
    pool.last_seen()[i] = f + 3;
  }
  // Copies of everything that must not change.
  const std::vector<uint8_t> labels(pool.labels(), pool.labels() + 3000 * SurfelPool::kLabelBytesPerSurfel);
  const std::vector<uint32_t> color(pool.color(), pool.color() + 3000);
  const std::vector<float> conf(pool.confidence(), pool.confidence() + 3000), radius(pool.radius(), pool.radius() + 3000);
  const std::vector<int32_t> init(pool.init_time(), pool.init_time() + 3000), seen(pool.last_seen(), pool.last_seen() + 3000);
  const std::vector<float> x0(pool.x(), pool.x() + 3000), y0(pool.y(), pool.y() + 3000);

  DeformationGraphOptions o;
  o.surfels_per_node = 100;  // 30 nodes
  DeformationGraph g = make_graph(o);
  ASSERT_TRUE(g.build(pool).ok());
  EXPECT_EQ(g.nodes(), 30);
  for (int f = 0; f < 50; f += 5) g.add_constraint(Path::point(f), f, Path::point(f));
  for (int f = 250; f < 300; f += 5) g.add_constraint(Path::point(f), f, Path::point(f) + Eigen::Vector3f(0, 0.08f, 0));
  DeformationResult r;
  ASSERT_TRUE(g.optimise(&r).ok());
  EXPECT_LT(r.rms_after_m, 0.005);
  g.apply(pool);

  EXPECT_EQ(std::memcmp(pool.labels(), labels.data(), labels.size()), 0) << "label distributions moved";
  int moved = 0;
  for (int i = 0; i < 3000; ++i) {
    ASSERT_EQ(pool.color()[i], color[i]);
    ASSERT_EQ(pool.confidence()[i], conf[i]);
    ASSERT_EQ(pool.radius()[i], radius[i]);
    ASSERT_EQ(pool.init_time()[i], init[i]);
    ASSERT_EQ(pool.last_seen()[i], seen[i]);
    const Eigen::Vector3f n(pool.nx()[i], pool.ny()[i], pool.nz()[i]);
    EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
    moved += std::abs(pool.y()[i] - y0[i]) > 0.05f ? 1 : 0;
    if (init[i] < 40) {
      EXPECT_LT(std::abs(pool.y()[i] - y0[i]) + std::abs(pool.x()[i] - x0[i]), 0.004f) << i;
    }
  }
  EXPECT_GT(moved, 300);  // the late part of the path moved
}

TEST(DeformationGraph, OptimisingAndApplyingAllocateNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  DeformationGraph g = make_graph();
  const Path path;
  SurfelPoolOptions po;
  po.capacity = 100;
  auto pool = SurfelPool::create(po);
  ASSERT_TRUE(pool.ok());
  for (int f = 0; f < 100; ++f) pool->append(0.01f * f, 0, 1, 0, 0, -1, 0.004f, 1, 0, f * 3);
  test::AllocationCounter count;
  ASSERT_TRUE(g.build(path.nodes.data(), path.times.data(), static_cast<int32_t>(path.nodes.size())).ok());
  for (int f = 200; f < 300; f += 5) g.add_constraint(Path::point(f), f, Path::point(f) + Eigen::Vector3f(0, 0.05f, 0));
  DeformationResult r;
  ASSERT_TRUE(g.optimise(&r).ok());
  g.apply(*pool);
  (void)g.apply_pose(SE3(), 150);
  ASSERT_TRUE(g.build(*pool).ok());
  EXPECT_EQ(count.thread_allocations(), 0u);
}

}  // namespace
}  // namespace ef::slam
