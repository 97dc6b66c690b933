#pragma once
// Sim(3): similarity transforms p_b = s * R * p_a + t (scale s > 0, unitless). Used where
// monocular-style scale drift or an unknown map scale must be estimated (alignment, loop
// closure). Tangent ordering (rho, phi, sigma) with s = exp(sigma), as in Sophus.

#include <Eigen/Core>

#include "slam/core/se3.hpp"

namespace coloc {

using Vector7d = Eigen::Matrix<double, 7, 1>;

class Sim3 {
 public:
  Sim3() = default;
  // Throws coloc::Error when scale <= 0.
  Sim3(double scale, const SO3& rotation, const Eigen::Vector3d& translation);
  explicit Sim3(const SE3& pose) : rotation_(pose.so3()), translation_(pose.translation()) {}
  // From a 4x4 matrix [sR t; 0 1]; scale from the cube root of det(sR).
  static Sim3 from_matrix(const Eigen::Matrix4d& m);

  static Sim3 exp(const Vector7d& xi);
  Vector7d log() const;

  double scale() const { return scale_; }
  const SO3& so3() const { return rotation_; }
  Eigen::Matrix3d rotation() const { return rotation_.matrix(); }
  const Eigen::Vector3d& translation() const { return translation_; }
  Eigen::Matrix4d matrix() const;
  // The rigid part (scale dropped).
  SE3 to_se3() const { return {rotation_, translation_}; }

  Sim3 inverse() const;
  Sim3 operator*(const Sim3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const {
    return scale_ * (rotation_ * p) + translation_;
  }

 private:
  double scale_ = 1.0;
  SO3 rotation_;
  Eigen::Vector3d translation_ = Eigen::Vector3d::Zero();
};

namespace detail {
// W(phi, sigma) = integral_0^1 exp(sigma u) exp(u hat(phi)) du: maps rho to the translation.
Eigen::Matrix3d sim3_w(const Eigen::Vector3d& phi, double sigma);
}  // namespace detail

}  // namespace coloc
