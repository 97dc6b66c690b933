#pragma once
// Shared helpers of the markers tests: poses that face a camera and intrinsics from OpenCV files.

#include <filesystem>
#include <opencv2/core.hpp>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::markers::test {

// camera_from_marker of a marker `distance` metres in front of the camera, its face toward the
// camera, its centre shifted by (dx, dy) metres in the camera's x/y, then tilted by tilt_x about
// its own x axis and tilt_y about its own y axis (radians).
inline SE3 facing(double distance, double tilt_x = 0.0, double tilt_y = 0.0, double dx = 0.0,
                  double dy = 0.0) {
  // Marker z (out of the face) -> camera -z; marker y (up) -> camera -y (image up).
  const SO3 flip = SO3::from_axis_angle(Eigen::Vector3d::UnitX(), M_PI);
  const SO3 tilt = SO3::from_axis_angle(Eigen::Vector3d::UnitX(), tilt_x) *
                   SO3::from_axis_angle(Eigen::Vector3d::UnitY(), tilt_y);
  return SE3(flip * tilt, Eigen::Vector3d(dx, dy, distance));
}

inline PinholeCamera vga_camera() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 600.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  return camera;
}

// camera_matrix / distortion_coefficients as OpenCV's calibration samples write them.
inline PinholeCamera read_opencv_camera(const std::filesystem::path& path, int width, int height) {
  cv::FileStorage fs(path.string(), cv::FileStorage::READ);
  cv::Mat k, d;
  fs["camera_matrix"] >> k;
  fs["distortion_coefficients"] >> d;
  PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = k.at<double>(0, 0);
  camera.fy = k.at<double>(1, 1);
  camera.cx = k.at<double>(0, 2);
  camera.cy = k.at<double>(1, 2);
  for (int i = 0; i < 5 && i < static_cast<int>(d.total()); ++i)
    camera.distortion[i] = d.at<double>(i);
  return camera;
}

}  // namespace coloc::markers::test
