#include "slam/core/camera.hpp"

#include <Eigen/LU>
#include <cmath>
#include <limits>

namespace coloc {
namespace {

Eigen::Matrix3d make_k(double fx, double fy, double cx, double cy) {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  k(0, 0) = fx;
  k(1, 1) = fy;
  k(0, 2) = cx;
  k(1, 2) = cy;
  return k;
}

// d (x/z, y/z) / d p.
Eigen::Matrix<double, 2, 3> normalize_jacobian(const Eigen::Vector3d& p) {
  const double iz = 1.0 / p.z();
  Eigen::Matrix<double, 2, 3> j;
  j << iz, 0.0, -p.x() * iz * iz, 0.0, iz, -p.y() * iz * iz;
  return j;
}

}  // namespace

// ---------------------------------------------------------------------------------- pinhole

bool PinholeCamera::has_distortion() const {
  for (double d : distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

Eigen::Matrix3d PinholeCamera::intrinsic_matrix() const {
  return make_k(fx, fy, cx, cy);
}

Eigen::Vector2d PinholeCamera::distort(const Eigen::Vector2d& xy) const {
  const auto [k1, k2, p1, p2, k3] = distortion;
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

Eigen::Matrix2d PinholeCamera::distort_jacobian(const Eigen::Vector2d& xy) const {
  const auto [k1, k2, p1, p2, k3] = distortion;
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double d_radial_d_r2 = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
  Eigen::Matrix2d j;
  j(0, 0) = radial + 2.0 * x * x * d_radial_d_r2 + 2.0 * p1 * y + 6.0 * p2 * x;
  j(0, 1) = 2.0 * x * y * d_radial_d_r2 + 2.0 * p1 * x + 2.0 * p2 * y;
  j(1, 0) = 2.0 * x * y * d_radial_d_r2 + 2.0 * p1 * x + 2.0 * p2 * y;
  j(1, 1) = radial + 2.0 * y * y * d_radial_d_r2 + 6.0 * p1 * y + 2.0 * p2 * x;
  return j;
}

Eigen::Vector2d PinholeCamera::undistort(const Eigen::Vector2d& xy_distorted) const {
  if (!has_distortion()) return xy_distorted;
  // Gauss-Newton on distort(xy) = xy_distorted, starting at the distorted point; converges in
  // a few steps inside the image for real lenses.
  Eigen::Vector2d xy = xy_distorted;
  for (int it = 0; it < 20; ++it) {
    const Eigen::Vector2d r = distort(xy) - xy_distorted;
    if (r.squaredNorm() < 1e-24) break;
    xy -= distort_jacobian(xy).partialPivLu().solve(r);
  }
  return xy;
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& p_cam) const {
  const Eigen::Vector2d xy = distort(p_cam.head<2>() / p_cam.z());
  return {fx * xy.x() + cx, fy * xy.y() + cy};
}

Eigen::Matrix<double, 2, 3> PinholeCamera::project_jacobian(const Eigen::Vector3d& p_cam) const {
  const Eigen::Vector2d xy = p_cam.head<2>() / p_cam.z();
  const Eigen::Matrix2d f = Eigen::Vector2d(fx, fy).asDiagonal();
  return f * distort_jacobian(xy) * normalize_jacobian(p_cam);
}

Eigen::Vector3d PinholeCamera::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d xy = undistort({(pixel.x() - cx) / fx, (pixel.y() - cy) / fy});
  return Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

// ----------------------------------------------------------------------------- Kannala-Brandt

Eigen::Matrix3d KannalaBrandtCamera::intrinsic_matrix() const {
  return make_k(fx, fy, cx, cy);
}

double KannalaBrandtCamera::distort_angle(double theta) const {
  const auto [k1, k2, k3, k4] = distortion;
  const double t2 = theta * theta;
  return theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
}

double KannalaBrandtCamera::undistort_angle(double theta_d) const {
  const auto [k1, k2, k3, k4] = distortion;
  double theta = theta_d;
  for (int it = 0; it < 20; ++it) {
    const double t2 = theta * theta;
    const double f = distort_angle(theta) - theta_d;
    const double df = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
    const double step = f / df;
    theta -= step;
    if (std::abs(step) < 1e-14) break;
  }
  return theta;
}

Eigen::Vector2d KannalaBrandtCamera::project(const Eigen::Vector3d& p_cam) const {
  const double r = p_cam.head<2>().norm();
  if (r < 1e-12 * std::abs(p_cam.z())) {
    return {fx * p_cam.x() / p_cam.z() + cx, fy * p_cam.y() / p_cam.z() + cy};
  }
  const double theta_d = distort_angle(std::atan2(r, p_cam.z()));
  return {fx * theta_d * p_cam.x() / r + cx, fy * theta_d * p_cam.y() / r + cy};
}

Eigen::Matrix<double, 2, 3> KannalaBrandtCamera::project_jacobian(
    const Eigen::Vector3d& p_cam) const {
  const double x = p_cam.x();
  const double y = p_cam.y();
  const double z = p_cam.z();
  const double r2 = x * x + y * y;
  const double r = std::sqrt(r2);
  Eigen::Matrix<double, 2, 3> j;
  if (r < 1e-8 * std::abs(z)) {
    // Limit r -> 0 of the expressions below (see the derivation in the comment there).
    const double k1 = distortion[0];
    const double c = (2.0 * k1 - 2.0 / 3.0) / (z * z * z);
    const double psi = 1.0 / z;
    j << fx * (psi + x * x * c), fx * x * y * c, -fx * x / (z * z),  //
        fy * x * y * c, fy * (psi + y * y * c), -fy * y / (z * z);
    return j;
  }
  // pixel = f * psi * (x, y) + c with psi = theta_d(theta) / r and theta = atan2(r, z).
  const double big_r2 = r2 + z * z;
  const double theta = std::atan2(r, z);
  const auto [k1, k2, k3, k4] = distortion;
  const double t2 = theta * theta;
  const double theta_d = distort_angle(theta);
  const double dtheta_d = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
  const double psi = theta_d / r;
  // d psi / d x = x / r^2 (theta_d' z / R^2 - theta_d / r), same for y; d psi / dz = -theta_d'/R^2.
  const double g = (dtheta_d * z / big_r2 - psi) / r2;
  const double dpsi_dz = -dtheta_d / big_r2;
  j << fx * (psi + x * x * g), fx * x * y * g, fx * x * dpsi_dz,  //
      fy * x * y * g, fy * (psi + y * y * g), fy * y * dpsi_dz;
  return j;
}

Eigen::Vector3d KannalaBrandtCamera::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d m((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  const double theta_d = m.norm();
  if (theta_d < 1e-12) return Eigen::Vector3d(m.x(), m.y(), 1.0).normalized();
  const double theta = undistort_angle(theta_d);
  const double s = std::sin(theta) / theta_d;
  return {s * m.x(), s * m.y(), std::cos(theta)};
}

// -------------------------------------------------------------------------------- dispatch

Eigen::Vector2d project(const Camera& camera, const Eigen::Vector3d& p_cam) {
  return std::visit([&](const auto& c) { return c.project(p_cam); }, camera);
}

Eigen::Matrix<double, 2, 3> project_jacobian(const Camera& camera, const Eigen::Vector3d& p_cam) {
  return std::visit([&](const auto& c) { return c.project_jacobian(p_cam); }, camera);
}

Eigen::Vector3d unproject(const Camera& camera, const Eigen::Vector2d& pixel) {
  return std::visit([&](const auto& c) { return c.unproject(pixel); }, camera);
}

Eigen::Vector3d backproject(const Camera& camera, const Eigen::Vector2d& pixel, double depth) {
  const Eigen::Vector3d ray = unproject(camera, pixel);
  return ray * (depth / ray.z());
}

Eigen::Vector2d undistort_pixel(const Camera& camera, const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d ray = unproject(camera, pixel);
  if (ray.z() <= 0.0) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  const Eigen::Matrix3d k = intrinsic_matrix(camera);
  return {k(0, 0) * ray.x() / ray.z() + k(0, 2), k(1, 1) * ray.y() / ray.z() + k(1, 2)};
}

Eigen::Matrix3d intrinsic_matrix(const Camera& camera) {
  return std::visit([](const auto& c) { return c.intrinsic_matrix(); }, camera);
}

int image_width(const Camera& camera) {
  return std::visit([](const auto& c) { return c.width; }, camera);
}

int image_height(const Camera& camera) {
  return std::visit([](const auto& c) { return c.height; }, camera);
}

std::string model_name(const Camera& camera) {
  return std::holds_alternative<PinholeCamera>(camera) ? "PinHole" : "KannalaBrandt8";
}

bool in_image(const Camera& camera, const Eigen::Vector2d& pixel, double border) {
  return pixel.x() >= border && pixel.y() >= border &&
         pixel.x() <= image_width(camera) - 1 - border &&
         pixel.y() <= image_height(camera) - 1 - border;
}

}  // namespace coloc
