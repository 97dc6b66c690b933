#include "slam/core/se3.hpp"

#include <cmath>

namespace coloc {
namespace {

// The Q block of the SE(3) left Jacobian (Barfoot, eq. 7.86), with the series of its three
// coefficients below 0.1 rad where the closed forms cancel.
Eigen::Matrix3d q_block(const Eigen::Vector3d& rho, const Eigen::Vector3d& phi) {
  const double t = phi.norm();
  const double t2 = t * t;
  double c1 = 0.0;
  double c2 = 0.0;
  double c3 = 0.0;
  if (t < 0.1) {
    c1 = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
    c2 = 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0;
    c3 = 1.0 / 120.0 - t2 / 2520.0 + t2 * t2 / 120960.0;
  } else {
    const double s = std::sin(t);
    const double c = std::cos(t);
    c1 = (t - s) / (t2 * t);
    c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2);
    c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t2 * t2 * t);
  }
  const Eigen::Matrix3d p = SO3::hat(phi);
  const Eigen::Matrix3d r = SO3::hat(rho);
  const Eigen::Matrix3d prp = p * r * p;
  return 0.5 * r + c1 * (p * r + r * p + prp) + c2 * (p * p * r + r * p * p - 3.0 * prp) +
         c3 * (prp * p + p * prp);
}

}  // namespace

SE3 SE3::from_matrix(const Eigen::Matrix4d& m) {
  return {SO3::from_matrix(m.topLeftCorner<3, 3>()), m.topRightCorner<3, 1>()};
}

SE3 SE3::from_matrix3x4(const Eigen::Matrix<double, 3, 4>& m) {
  return {SO3::from_matrix(m.leftCols<3>()), m.col(3)};
}

SE3 SE3::exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  return {SO3::exp(phi), SO3::left_jacobian(phi) * rho};
}

Vector6d SE3::log() const {
  Vector6d xi;
  const Eigen::Vector3d phi = rotation_.log();
  xi.head<3>() = SO3::left_jacobian_inverse(phi) * translation_;
  xi.tail<3>() = phi;
  return xi;
}

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation();
  m.topRightCorner<3, 1>() = translation_;
  return m;
}

Eigen::Matrix<double, 3, 4> SE3::matrix3x4() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = rotation();
  m.col(3) = translation_;
  return m;
}

SE3 SE3::inverse() const {
  const SO3 r_inv = rotation_.inverse();
  return {r_inv, -(r_inv * translation_)};
}

SE3 SE3::operator*(const SE3& other) const {
  return {rotation_ * other.rotation_, rotation_ * other.translation_ + translation_};
}

Matrix6d SE3::adjoint() const {
  Matrix6d ad = Matrix6d::Zero();
  const Eigen::Matrix3d r = rotation();
  ad.topLeftCorner<3, 3>() = r;
  ad.topRightCorner<3, 3>() = SO3::hat(translation_) * r;
  ad.bottomRightCorner<3, 3>() = r;
  return ad;
}

Eigen::Matrix4d SE3::hat(const Vector6d& xi) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() = SO3::hat(xi.tail<3>());
  m.topRightCorner<3, 1>() = xi.head<3>();
  return m;
}

Matrix6d SE3::left_jacobian(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  const Eigen::Matrix3d jl = SO3::left_jacobian(phi);
  Matrix6d j = Matrix6d::Zero();
  j.topLeftCorner<3, 3>() = jl;
  j.bottomRightCorner<3, 3>() = jl;
  j.topRightCorner<3, 3>() = q_block(rho, phi);
  return j;
}

Matrix6d SE3::right_jacobian(const Vector6d& xi) {
  return left_jacobian(-xi);
}

SE3 interpolate(const SE3& a, const SE3& b, double t) {
  return {interpolate(a.so3(), b.so3(), t), (1.0 - t) * a.translation() + t * b.translation()};
}

double translation_distance(const SE3& a, const SE3& b) {
  return (a.translation() - b.translation()).norm();
}

double rotation_distance(const SE3& a, const SE3& b) {
  return angular_distance(a.so3(), b.so3());
}

}  // namespace coloc
