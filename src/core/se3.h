// Rigid transforms in 3D (SE3), in double precision, on Eigen.
//
// Naming: T_ab maps points from frame b into frame a (p_a = T_ab * p_b). The camera pose of a frame
// is T_wc: camera to world, the convention of TUM trajectories. Units: metres and radians.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ef {

using Vector6d = Eigen::Matrix<double, 6, 1>;

class SE3 {
 public:
  SE3() : q_(Eigen::Quaterniond::Identity()), t_(Eigen::Vector3d::Zero()) {}
  SE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : q_(q.normalized()), t_(t) {}
  SE3(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) : q_(Eigen::Quaterniond(R).normalized()), t_(t) {}
  // From a 4x4 homogeneous matrix; the rotation block is re-orthonormalised through the quaternion.
  explicit SE3(const Eigen::Matrix4d& m) : SE3(Eigen::Matrix3d(m.topLeftCorner<3, 3>()), Eigen::Vector3d(m.topRightCorner<3, 1>())) {}

  static SE3 identity() { return SE3(); }
  // The quaternion taken as it is, not normalised again: a pose read back bit for bit (a checkpoint,
  // pipeline/checkpoint.h). `q` must be a unit quaternion.
  static SE3 from_unit_quaternion(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
    SE3 T;
    T.q_ = q;
    T.t_ = t;
    return T;
  }

  // Exponential map of a twist xi = (v, w): translation part v (metres), rotation part w (axis-angle, radians).
  static SE3 exp(const Vector6d& xi);
  // Inverse of exp: the twist (v, w) of this transform.
  Vector6d log() const;

  const Eigen::Quaterniond& rotation() const { return q_; }
  Eigen::Matrix3d rotation_matrix() const { return q_.toRotationMatrix(); }
  const Eigen::Vector3d& translation() const { return t_; }
  Eigen::Matrix4d matrix() const;

  SE3 inverse() const {
    const Eigen::Quaterniond qi = q_.conjugate();
    return SE3(qi, -(qi * t_));
  }
  SE3 operator*(const SE3& o) const { return SE3(q_ * o.q_, t_ + q_ * o.t_); }
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return q_ * p + t_; }
  Eigen::Vector3f operator*(const Eigen::Vector3f& p) const { return (q_ * p.cast<double>() + t_).cast<float>(); }

  // Rotation angle of this transform, radians in [0, pi].
  double angle() const;

  // As 7 doubles, translation xyz then quaternion xyzw (the TUM order): how checkpoints, the pose
  // history and the keyframe database store a pose. from_words takes the quaternion as it is (bit
  // for bit, as from_unit_quaternion); words_are_pose says whether 7 stored words are one (finite
  // translation, quaternion within 1e-6 of unit length), for data read back from a file.
  static constexpr int kWords = 7;
  void to_words(double* w) const;
  static SE3 from_words(const double* w) {
    return from_unit_quaternion(Eigen::Quaterniond(w[6], w[3], w[4], w[5]), Eigen::Vector3d(w[0], w[1], w[2]));
  }
  static bool words_are_pose(const double* w);

 private:
  Eigen::Quaterniond q_;  // unit quaternion
  Eigen::Vector3d t_;     // metres
};

// 3x3 skew-symmetric matrix of w: hat(w) * v = w x v.
Eigen::Matrix3d hat(const Eigen::Vector3d& w);

}  // namespace ef
