#include "slam/core/sim3.hpp"

#include <cmath>

#include "slam/core/error.hpp"

namespace coloc {
namespace detail {
namespace {

// f_n(sigma) = integral_0^1 u^n exp(sigma u) du, by its power series (exact for the small
// |sigma| where the closed forms cancel) or by recursion f_n = (e^s - n f_{n-1}) / s.
double moment(int n, double sigma) {
  if (std::abs(sigma) < 0.5) {
    double sum = 0.0;
    double term = 1.0;  // sigma^k / k!
    for (int k = 0; k < 30; ++k) {
      sum += term / (n + k + 1);
      term *= sigma / (k + 1);
    }
    return sum;
  }
  const double e = std::exp(sigma);
  double f = (e - 1.0) / sigma;
  for (int i = 1; i <= n; ++i)
    f = (e - i * f) / sigma;
  return f;
}

}  // namespace

Eigen::Matrix3d sim3_w(const Eigen::Vector3d& phi, double sigma) {
  const double theta = phi.norm();
  const Eigen::Matrix3d p = SO3::hat(phi);
  const double a = moment(0, sigma);
  double b = 0.0;  // coefficient of hat(phi): integral e^{su} sin(theta u) / theta
  double c = 0.0;  // coefficient of hat(phi)^2: integral e^{su} (1 - cos(theta u)) / theta^2
  if (theta < 1e-3) {
    const double t2 = theta * theta;
    b = moment(1, sigma) - t2 / 6.0 * moment(3, sigma);
    c = 0.5 * moment(2, sigma) - t2 / 24.0 * moment(4, sigma);
  } else {
    const double e = std::exp(sigma);
    const double d = sigma * sigma + theta * theta;
    const double s = std::sin(theta);
    const double co = std::cos(theta);
    const double int_sin = (e * (sigma * s - theta * co) + theta) / d;
    const double int_cos = (e * (sigma * co + theta * s) - sigma) / d;
    b = int_sin / theta;
    c = (a - int_cos) / (theta * theta);
  }
  return a * Eigen::Matrix3d::Identity() + b * p + c * p * p;
}

}  // namespace detail

Sim3::Sim3(double scale, const SO3& rotation, const Eigen::Vector3d& translation)
    : scale_(scale), rotation_(rotation), translation_(translation) {
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    throw Error("Sim3 scale must be positive and finite, got " + std::to_string(scale));
  }
}

Sim3 Sim3::from_matrix(const Eigen::Matrix4d& m) {
  const Eigen::Matrix3d sr = m.topLeftCorner<3, 3>();
  const double det = sr.determinant();
  if (!(det > 0.0)) throw Error("Sim3 matrix has a non-positive determinant");
  const double s = std::cbrt(det);
  return {s, SO3::from_matrix(sr / s), m.topRightCorner<3, 1>()};
}

Sim3 Sim3::exp(const Vector7d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.segment<3>(3);
  const double sigma = xi(6);
  return {std::exp(sigma), SO3::exp(phi), detail::sim3_w(phi, sigma) * rho};
}

Vector7d Sim3::log() const {
  Vector7d xi;
  const Eigen::Vector3d phi = rotation_.log();
  const double sigma = std::log(scale_);
  xi.head<3>() = detail::sim3_w(phi, sigma).lu().solve(translation_);
  xi.segment<3>(3) = phi;
  xi(6) = sigma;
  return xi;
}

Eigen::Matrix4d Sim3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale_ * rotation();
  m.topRightCorner<3, 1>() = translation_;
  return m;
}

Sim3 Sim3::inverse() const {
  const SO3 r_inv = rotation_.inverse();
  const double s_inv = 1.0 / scale_;
  return {s_inv, r_inv, -s_inv * (r_inv * translation_)};
}

Sim3 Sim3::operator*(const Sim3& other) const {
  return {scale_ * other.scale_, rotation_ * other.rotation_,
          scale_ * (rotation_ * other.translation_) + translation_};
}

}  // namespace coloc
