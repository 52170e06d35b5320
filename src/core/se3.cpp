#include "core/se3.h"

#include <algorithm>
#include <cmath>

namespace ef {

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

namespace {
// Left Jacobian V of SO(3): t = V * v in exp((v, w)). Uses Taylor series near theta = 0.
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& w) {
  const double theta2 = w.squaredNorm();
  const Eigen::Matrix3d W = hat(w);
  double a, b;  // V = I + a W + b W^2
  if (theta2 < 1e-10) {
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = (1.0 - std::cos(theta)) / theta2;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * W + b * W * W;
}
}  // namespace

SE3 SE3::exp(const Vector6d& xi) {
  const Eigen::Vector3d v = xi.head<3>();
  const Eigen::Vector3d w = xi.tail<3>();
  const double theta = w.norm();
  Eigen::Quaterniond q;
  if (theta < 1e-10) {
    q = Eigen::Quaterniond(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z()).normalized();
  } else {
    q = Eigen::Quaterniond(Eigen::AngleAxisd(theta, w / theta));
  }
  return SE3(q, left_jacobian(w) * v);
}

Vector6d SE3::log() const {
  Eigen::Quaterniond q = q_;
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // shortest rotation
  const Eigen::Vector3d qv = q.vec();
  const double s = qv.norm();
  Eigen::Vector3d w;
  if (s < 1e-10) {
    w = 2.0 * qv / q.w();
  } else {
    const double theta = 2.0 * std::atan2(s, q.w());
    w = qv / s * theta;
  }
  Vector6d xi;
  xi.head<3>() = left_jacobian(w).inverse() * t_;
  xi.tail<3>() = w;
  return xi;
}

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = q_.toRotationMatrix();
  m.topRightCorner<3, 1>() = t_;
  return m;
}

double SE3::angle() const {
  // atan2 rather than acos(|w|): acos loses all precision for small angles (|w| rounds to 1).
  return 2.0 * std::atan2(q_.vec().norm(), std::abs(q_.w()));
}

void SE3::to_words(double* w) const {
  const double v[kWords] = {t_.x(), t_.y(), t_.z(), q_.x(), q_.y(), q_.z(), q_.w()};
  std::copy(v, v + kWords, w);
}

bool SE3::words_are_pose(const double* w) {
  const double norm2 = w[3] * w[3] + w[4] * w[4] + w[5] * w[5] + w[6] * w[6];
  return std::abs(norm2 - 1.0) < 1e-6 && std::isfinite(w[0] + w[1] + w[2]);
}

}  // namespace ef
