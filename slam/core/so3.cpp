#include "slam/core/so3.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace coloc {
namespace detail {

// Below these angles the closed forms lose digits to cancellation; the Taylor series (three
// terms) are exact to ~1e-16 there.
constexpr double kSmallAngle = 1e-2;

double sinc_a(double t) {
  if (std::abs(t) < kSmallAngle) return 1.0 - t * t / 6.0 + t * t * t * t / 120.0;
  return std::sin(t) / t;
}

double cos_b(double t) {
  const double t2 = t * t;
  if (std::abs(t) < kSmallAngle) return 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
  return (1.0 - std::cos(t)) / t2;
}

double sin_c(double t) {
  const double t2 = t * t;
  if (std::abs(t) < 0.1) return 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0;
  return (t - std::sin(t)) / (t2 * t);
}

double jl_inv_coeff(double t) {
  const double t2 = t * t;
  if (std::abs(t) < 0.1) return 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  // (1 + cos t) / sin t == cot(t / 2): the half-angle form has no 0/0 at t = pi.
  return 1.0 / t2 - std::cos(0.5 * t) / (2.0 * t * std::sin(0.5 * t));
}

}  // namespace detail

SO3::SO3(const Eigen::Quaterniond& q) : q_(q.normalized()) {}

SO3 SO3::from_matrix(const Eigen::Matrix3d& rotation) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(rotation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
  return SO3(Eigen::Quaterniond(r));
}

SO3 SO3::from_axis_angle(const Eigen::Vector3d& axis, double angle) {
  return exp(axis.normalized() * angle);
}

SO3 SO3::exp(const Eigen::Vector3d& omega) {
  const double theta = omega.norm();
  const double half = 0.5 * theta;
  // q = (cos(theta/2), sin(theta/2)/theta * omega); sin(x)/x via sinc_a keeps small angles exact.
  const double w = std::cos(half);
  const Eigen::Vector3d v = 0.5 * detail::sinc_a(half) * omega;
  return SO3(Eigen::Quaterniond(w, v.x(), v.y(), v.z()));
}

Eigen::Vector3d SO3::log() const {
  // Use the hemisphere w >= 0 so the angle is in [0, pi]; atan2 stays accurate near pi where
  // w -> 0 (acos would not) and near 0 where |v| -> 0.
  Eigen::Quaterniond q = q_;
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double n = v.norm();
  if (n < 1e-10) {
    // theta = 2 atan(n / w) ~= 2 n / w (1 - n^2 / (3 w^2)).
    return (2.0 / q.w()) * (1.0 - n * n / (3.0 * q.w() * q.w())) * v;
  }
  const double theta = 2.0 * std::atan2(n, q.w());
  return (theta / n) * v;
}

double SO3::angle() const {
  const double w = std::abs(q_.w());
  return 2.0 * std::atan2(q_.vec().norm(), w);
}

SO3 SO3::operator*(const SO3& other) const {
  // Renormalize: products of many rotations drift off the unit sphere.
  return SO3(q_ * other.q_);
}

Eigen::Matrix3d SO3::hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Vector3d SO3::vee(const Eigen::Matrix3d& m) {
  return {m(2, 1), m(0, 2), m(1, 0)};
}

Eigen::Matrix3d SO3::left_jacobian(const Eigen::Vector3d& omega) {
  const double theta = omega.norm();
  const Eigen::Matrix3d w = hat(omega);
  return Eigen::Matrix3d::Identity() + detail::cos_b(theta) * w + detail::sin_c(theta) * w * w;
}

Eigen::Matrix3d SO3::left_jacobian_inverse(const Eigen::Vector3d& omega) {
  const double theta = omega.norm();
  const Eigen::Matrix3d w = hat(omega);
  return Eigen::Matrix3d::Identity() - 0.5 * w + detail::jl_inv_coeff(theta) * w * w;
}

Eigen::Matrix3d SO3::right_jacobian(const Eigen::Vector3d& omega) {
  return left_jacobian(-omega);
}

Eigen::Matrix3d SO3::right_jacobian_inverse(const Eigen::Vector3d& omega) {
  return left_jacobian_inverse(-omega);
}

SO3 interpolate(const SO3& a, const SO3& b, double t) {
  return a * SO3::exp(t * (a.inverse() * b).log());
}

double angular_distance(const SO3& a, const SO3& b) {
  return (a.inverse() * b).angle();
}

}  // namespace coloc
