#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/se3.h"

namespace ef {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Reference exponential of the 4x4 twist matrix [hat(w) v; 0 0] by scaling and squaring of a
// Taylor series: independent of the closed-form Rodrigues / left-Jacobian code under test.
Eigen::Matrix4d reference_exp(const Vector6d& xi) {
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
  A.topLeftCorner<3, 3>() = hat(xi.tail<3>());
  A.topRightCorner<3, 1>() = xi.head<3>();
  int squarings = 0;
  double norm = A.norm();
  while (norm > 0.25) {
    norm /= 2;
    ++squarings;
  }
  const Eigen::Matrix4d B = A / std::pow(2.0, squarings);
  Eigen::Matrix4d sum = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 30; ++k) {
    term = term * B / k;
    sum += term;
  }
  for (int i = 0; i < squarings; ++i) sum = sum * sum;
  return sum;
}

Eigen::Vector3d random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d a(n(rng), n(rng), n(rng));
  return a.normalized();
}

Vector6d twist(const Eigen::Vector3d& v, const Eigen::Vector3d& w) {
  Vector6d xi;
  xi << v, w;
  return xi;
}

// Rotation angles that stress the small-angle and near-pi branches.
std::vector<double> test_angles(std::mt19937& rng) {
  std::vector<double> a = {0.0,    1e-14, 1e-12,  1e-10,      3e-6,       9.99e-6,    1e-5,       1.001e-5,
                           1e-4,   1e-3,  0.1,    1.0,        2.0,        3.0,        kPi - 1e-3, kPi - 1e-6,
                           kPi - 1e-9};
  std::uniform_real_distribution<double> u(0.0, kPi);
  for (int i = 0; i < 40; ++i) a.push_back(u(rng));
  return a;
}

void expect_se3_near(const SE3& a, const SE3& b, double tol) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tol) << "a=\n" << a.matrix() << "\nb=\n" << b.matrix();
}

TEST(SE3, HatIsCrossProduct) {
  const Eigen::Vector3d w(0.3, -1.2, 2.5), v(-0.7, 0.4, 1.1);
  EXPECT_LT((hat(w) * v - w.cross(v)).norm(), 1e-15);
  EXPECT_LT((hat(w) + hat(w).transpose()).norm(), 1e-15);
}

TEST(SE3, ExpMatchesReferenceMatrixExponential) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> t(-2.0, 2.0);
  for (double angle : test_angles(rng)) {
    const Vector6d xi = twist(Eigen::Vector3d(t(rng), t(rng), t(rng)), angle * random_unit(rng));
    const Eigen::Matrix4d ref = reference_exp(xi);
    const Eigen::Matrix4d got = SE3::exp(xi).matrix();
    EXPECT_LT((got - ref).cwiseAbs().maxCoeff(), 1e-9) << "angle " << angle << "\n" << got << "\nvs\n" << ref;
  }
}

TEST(SE3, LogInvertsExp) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> t(-3.0, 3.0);
  for (double angle : test_angles(rng)) {
    for (int rep = 0; rep < 3; ++rep) {
      const Vector6d xi = twist(Eigen::Vector3d(t(rng), t(rng), t(rng)), angle * random_unit(rng));
      const SE3 T = SE3::exp(xi);
      const Vector6d back = T.log();
      // Away from pi the twist itself comes back; at pi +w and -w are the same rotation.
      const double tol = angle > kPi - 1e-4 ? 1e-5 : 1e-9;
      EXPECT_LT((back - xi).cwiseAbs().maxCoeff(), tol) << "angle " << angle << " xi " << xi.transpose()
                                                        << " back " << back.transpose();
      expect_se3_near(SE3::exp(back), T, 1e-9);
    }
  }
}

TEST(SE3, LogOfRotationBeyondPiTakesTheShortWay) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -0.5).normalized();
  const SE3 T = SE3::exp(twist(Eigen::Vector3d(0.2, 0.1, -0.3), 1.5 * kPi * axis));
  const Vector6d xi = T.log();
  EXPECT_NEAR(xi.tail<3>().norm(), 0.5 * kPi, 1e-12);
  EXPECT_LT((xi.tail<3>().normalized() + axis).norm(), 1e-12);  // the opposite axis
  expect_se3_near(SE3::exp(xi), T, 1e-12);
  EXPECT_NEAR(T.angle(), 0.5 * kPi, 1e-12);
}

TEST(SE3, ComposeAndInverseIdentities) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> t(-2.0, 2.0), a(0.0, kPi);
  for (int i = 0; i < 50; ++i) {
    const SE3 A = SE3::exp(twist(Eigen::Vector3d(t(rng), t(rng), t(rng)), a(rng) * random_unit(rng)));
    const SE3 B = SE3::exp(twist(Eigen::Vector3d(t(rng), t(rng), t(rng)), a(rng) * random_unit(rng)));
    const SE3 C = SE3::exp(twist(Eigen::Vector3d(t(rng), t(rng), t(rng)), a(rng) * random_unit(rng)));
    expect_se3_near(A * A.inverse(), SE3::identity(), 1e-12);
    expect_se3_near(A.inverse() * A, SE3::identity(), 1e-12);
    expect_se3_near(A * SE3::identity(), A, 1e-15);
    expect_se3_near((A * B).inverse(), B.inverse() * A.inverse(), 1e-12);
    expect_se3_near((A * B) * C, A * (B * C), 1e-12);
    EXPECT_LT(((A * B).matrix() - A.matrix() * B.matrix()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((A.inverse().matrix() - A.matrix().inverse()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_NEAR(A.rotation().norm(), 1.0, 1e-15);
    EXPECT_NEAR((A * B * C).rotation().norm(), 1.0, 1e-15);
  }
}

TEST(SE3, ActionOnPointsMatchesMatrix) {
  std::mt19937 rng(14);
  std::uniform_real_distribution<double> t(-2.0, 2.0), a(0.0, kPi);
  for (int i = 0; i < 50; ++i) {
    const SE3 T = SE3::exp(twist(Eigen::Vector3d(t(rng), t(rng), t(rng)), a(rng) * random_unit(rng)));
    const Eigen::Vector3d p(t(rng), t(rng), t(rng));
    const Eigen::Vector4d ph = T.matrix() * p.homogeneous();
    EXPECT_LT((T * p - ph.head<3>()).norm(), 1e-12);
    EXPECT_LT((T.rotation_matrix() * p + T.translation() - T * p).norm(), 1e-12);
    const Eigen::Vector3f pf = p.cast<float>();
    EXPECT_LT((T * pf - (T * Eigen::Vector3d(pf.cast<double>())).cast<float>()).norm(), 1e-6f);
    EXPECT_LT((T.inverse() * (T * p) - p).norm(), 1e-12);
  }
  // p_a = T_ab * p_b with a known transform: rotate 90 degrees about z, then shift x by 1.
  const SE3 T(Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(1, 0, 0));
  EXPECT_LT((T * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(1, 1, 0)).norm(), 1e-15);
}

TEST(SE3, MatrixRoundTripAndReorthonormalisation) {
  const SE3 T = SE3::exp(twist(Eigen::Vector3d(0.5, -1, 2), Eigen::Vector3d(0.3, 0.2, -0.9)));
  expect_se3_near(SE3(T.matrix()), T, 1e-14);
  Eigen::Matrix4d m = T.matrix();
  m.topLeftCorner<3, 3>() *= 1.0 + 1e-7;  // slightly non-orthonormal input
  const SE3 U(m);
  EXPECT_NEAR(U.rotation().norm(), 1.0, 1e-15);
  const Eigen::Matrix3d R = U.rotation_matrix();
  EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  expect_se3_near(U, T, 1e-6);
  // A non-unit quaternion is normalised by the constructor.
  const SE3 V(Eigen::Quaterniond(2, 0, 0, 0), Eigen::Vector3d(1, 2, 3));
  expect_se3_near(V, SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3)), 1e-15);
}

TEST(SE3, AngleIsRotationAngle) {
  std::mt19937 rng(15);
  for (double angle : test_angles(rng)) {
    const SE3 T = SE3::exp(twist(Eigen::Vector3d(1, 2, 3), angle * random_unit(rng)));
    // Relative accuracy also for tiny angles (motion thresholds compare small angles).
    EXPECT_NEAR(T.angle(), angle, 1e-9 * std::max(angle, 1e-6)) << "angle " << angle;
    EXPECT_NEAR(T.inverse().angle(), angle, 1e-9 * std::max(angle, 1e-6)) << "angle " << angle;
    EXPECT_GE(T.angle(), 0.0);
    EXPECT_LE(T.angle(), kPi);
  }
  EXPECT_EQ(SE3::identity().angle(), 0.0);
  // q and -q are the same rotation.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()));
  EXPECT_NEAR(SE3(Eigen::Quaterniond(-q.coeffs()), Eigen::Vector3d::Zero()).angle(), 0.7, 1e-14);
}

}  // namespace
}  // namespace ef
