#pragma once
// Camera models as plain values. Camera frame: x right, y down, z forward (metres); pixel
// coordinates with the origin at the centre of the top-left pixel.
//
//  - PinholeCamera: OpenCV / ORB-SLAM radial-tangential distortion (k1 k2 p1 p2 k3).
//  - KannalaBrandtCamera: equidistant fisheye, theta_d = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 +
//    k4 t^8), as ORB-SLAM3's "KannalaBrandt8" and OpenCV's fisheye module.
//
// `Camera` is a variant over the models; the free functions below dispatch on it.

#include <Eigen/Core>
#include <array>
#include <string>
#include <variant>

namespace coloc {

struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::array<double, 5> distortion{};  // k1 k2 p1 p2 k3

  bool has_distortion() const;
  Eigen::Matrix3d intrinsic_matrix() const;
  // Pixel of a camera-frame point with z > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const;
  // d pixel / d p_cam.
  Eigen::Matrix<double, 2, 3> project_jacobian(const Eigen::Vector3d& p_cam) const;
  // Unit-norm bearing of a pixel (distortion removed).
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;
  // Distortion on normalized coordinates (x/z, y/z), and its inverse by Gauss-Newton.
  Eigen::Vector2d distort(const Eigen::Vector2d& xy) const;
  Eigen::Matrix2d distort_jacobian(const Eigen::Vector2d& xy) const;
  Eigen::Vector2d undistort(const Eigen::Vector2d& xy_distorted) const;
  bool operator==(const PinholeCamera&) const = default;
};

struct KannalaBrandtCamera {
  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::array<double, 4> distortion{};  // k1 k2 k3 k4

  Eigen::Matrix3d intrinsic_matrix() const;
  // Pixel of a camera-frame point (any direction except exactly backwards).
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const;
  Eigen::Matrix<double, 2, 3> project_jacobian(const Eigen::Vector3d& p_cam) const;
  // Unit-norm bearing; valid beyond 90 degrees off-axis.
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;
  double distort_angle(double theta) const;
  // Inverse of distort_angle by Newton's method.
  double undistort_angle(double theta_d) const;
  bool operator==(const KannalaBrandtCamera&) const = default;
};

using Camera = std::variant<PinholeCamera, KannalaBrandtCamera>;

Eigen::Vector2d project(const Camera& camera, const Eigen::Vector3d& p_cam);
Eigen::Matrix<double, 2, 3> project_jacobian(const Camera& camera, const Eigen::Vector3d& p_cam);
Eigen::Vector3d unproject(const Camera& camera, const Eigen::Vector2d& pixel);
// The camera-frame point at a pixel with the given depth (z, metres), as RGB-D cameras report.
Eigen::Vector3d backproject(const Camera& camera, const Eigen::Vector2d& pixel, double depth);
// Maps a distorted pixel to the pixel an ideal pinhole with the same fx fy cx cy would see;
// this is what ORB-SLAM does to keypoints before matching. NaN when the ray points backwards.
Eigen::Vector2d undistort_pixel(const Camera& camera, const Eigen::Vector2d& pixel);
Eigen::Matrix3d intrinsic_matrix(const Camera& camera);
int image_width(const Camera& camera);
int image_height(const Camera& camera);
// "PinHole" or "KannalaBrandt8" (the names ORB-SLAM3 settings use).
std::string model_name(const Camera& camera);
// True when the pixel lies inside the image with the given border (pixels).
bool in_image(const Camera& camera, const Eigen::Vector2d& pixel, double border = 0.0);

}  // namespace coloc
