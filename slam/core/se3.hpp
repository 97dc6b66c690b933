#pragma once
// SE(3): rigid transforms. A pose named b_from_a maps points from frame a to frame b:
//   p_b = b_from_a * p_a = R * p_a + t.
// Tangent vectors are ordered (rho, phi): translation part (metres) first, rotation (radians)
// second, as in Sophus. exp((rho, phi)) = [exp(phi), J_l(phi) * rho].

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/core/so3.hpp"

namespace coloc {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

class SE3 {
 public:
  SE3() = default;
  SE3(const SO3& rotation, const Eigen::Vector3d& translation)
      : rotation_(rotation), translation_(translation) {}
  SE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& translation)
      : rotation_(q), translation_(translation) {}
  // From a 4x4 (or top 3x4) homogeneous matrix; the rotation block is projected onto SO(3).
  static SE3 from_matrix(const Eigen::Matrix4d& m);
  static SE3 from_matrix3x4(const Eigen::Matrix<double, 3, 4>& m);

  static SE3 exp(const Vector6d& xi);
  Vector6d log() const;

  const SO3& so3() const { return rotation_; }
  Eigen::Matrix3d rotation() const { return rotation_.matrix(); }
  const Eigen::Quaterniond& quaternion() const { return rotation_.quaternion(); }
  const Eigen::Vector3d& translation() const { return translation_; }
  Eigen::Vector3d& translation() { return translation_; }
  Eigen::Matrix4d matrix() const;
  Eigen::Matrix<double, 3, 4> matrix3x4() const;

  SE3 inverse() const;
  SE3 operator*(const SE3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation_ * p + translation_; }

  // Adjoint for the (rho, phi) ordering: T * exp(xi) * T^-1 = exp(adjoint() * xi).
  Matrix6d adjoint() const;

  // hat(xi) is the 4x4 twist matrix.
  static Eigen::Matrix4d hat(const Vector6d& xi);

  // exp(xi + d) ~= exp(left_jacobian(xi) d) exp(xi) ~= exp(xi) exp(right_jacobian(xi) d).
  static Matrix6d left_jacobian(const Vector6d& xi);
  static Matrix6d right_jacobian(const Vector6d& xi);

 private:
  SO3 rotation_;
  Eigen::Vector3d translation_ = Eigen::Vector3d::Zero();
};

// Pose interpolation as trajectories use it: slerp of the rotation and linear interpolation of
// the translation (decoupled, so a straight path stays straight); a at t = 0, b at t = 1.
SE3 interpolate(const SE3& a, const SE3& b, double t);

// Translation distance (metres) and rotation distance (radians) between two poses.
double translation_distance(const SE3& a, const SE3& b);
double rotation_distance(const SE3& a, const SE3& b);

}  // namespace coloc
