#pragma once
// SO(3): 3-D rotations, stored as a unit quaternion (Hamilton, w + xi + yj + zk, column vectors,
// active rotation: R * p rotates the point p). Tangent vectors are rotation vectors in radians.
//
// Jacobian conventions (Barfoot, "State Estimation for Robotics"):
//   exp(phi + d) ~= exp(phi) * exp(right_jacobian(phi) * d) ~= exp(left_jacobian(phi) * d) *
//   exp(phi)

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace coloc {

class SO3 {
 public:
  SO3() = default;
  // Normalizes q; q and -q give the same rotation.
  explicit SO3(const Eigen::Quaterniond& q);
  // Projects R to the nearest rotation (SVD), so slightly non-orthogonal input is accepted.
  static SO3 from_matrix(const Eigen::Matrix3d& rotation);
  static SO3 from_axis_angle(const Eigen::Vector3d& axis, double angle);
  // Takes q as it is, without normalizing: for a rotation read back bit for bit from a file
  // that saved quaternion() (slam/mapdb), where renormalizing would change the last bits. The
  // caller guarantees |q| = 1 to rounding.
  static SO3 from_unit_quaternion(const Eigen::Quaterniond& q) { return SO3(q, NoNormalize{}); }

  // Exponential map; accurate for |omega| near 0 (Taylor series) and up to and beyond pi.
  static SO3 exp(const Eigen::Vector3d& omega);
  // Logarithm: rotation vector with angle in [0, pi]; accurate near 0 and near pi.
  Eigen::Vector3d log() const;
  // Rotation angle in [0, pi].
  double angle() const;

  Eigen::Matrix3d matrix() const { return q_.toRotationMatrix(); }
  const Eigen::Quaterniond& quaternion() const { return q_; }
  SO3 inverse() const { return SO3(q_.conjugate(), NoNormalize{}); }

  SO3 operator*(const SO3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return q_ * p; }
  // Adjoint: R * hat(w) * R^T = hat(Ad * w); for SO(3) Ad = R.
  Eigen::Matrix3d adjoint() const { return matrix(); }

  static Eigen::Matrix3d hat(const Eigen::Vector3d& v);
  static Eigen::Vector3d vee(const Eigen::Matrix3d& m);

  static Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& omega);
  static Eigen::Matrix3d left_jacobian_inverse(const Eigen::Vector3d& omega);
  static Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& omega);
  static Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& omega);

 private:
  struct NoNormalize {};
  SO3(const Eigen::Quaterniond& q, NoNormalize) : q_(q) {}
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
};

// Geodesic interpolation: a at t = 0, b at t = 1 (slerp along the shorter arc).
SO3 interpolate(const SO3& a, const SO3& b, double t);

// Angle of a^-1 * b in radians, in [0, pi].
double angular_distance(const SO3& a, const SO3& b);

namespace detail {
// Coefficients of the SO(3)/SE(3) series, with Taylor expansions where the closed forms cancel.
double sinc_a(double theta);        // sin(t)/t
double cos_b(double theta);         // (1 - cos t) / t^2
double sin_c(double theta);         // (t - sin t) / t^3
double jl_inv_coeff(double theta);  // 1/t^2 - (1 + cos t) / (2 t sin t)
}  // namespace detail

}  // namespace coloc
