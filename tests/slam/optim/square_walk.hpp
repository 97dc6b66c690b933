#pragma once
// A camera at 1.6 m walking around a 4 m square, looking ahead (camera z forward, y down), n
// poses evenly along it: the headings turn, which the IMU tests need (a gyro or accelerometer
// bias fixed in the camera can then be told from a drift).
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "slam/core/se3.hpp"

namespace coloc::slam::optim {

inline std::vector<SE3> square_walk(int n) {
  std::vector<SE3> world_from_cam;
  const Eigen::Matrix3d level = (Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  const Eigen::Vector2d corners[4] = {{0, 0}, {4, 0}, {4, 4}, {0, 4}};
  for (int i = 0; i < n; ++i) {
    const double s = 16.0 * i / n;  // metres along the square
    const int side = static_cast<int>(s / 4.0);
    const double along = s - 4.0 * side;
    const Eigen::Vector2d dir = (corners[(side + 1) % 4] - corners[side]) / 4.0;
    const Eigen::Vector2d xy = corners[side] + along * dir;
    const double yaw = std::atan2(dir.y(), dir.x());
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).matrix() * level;
    world_from_cam.emplace_back(SO3(Eigen::Quaterniond(rot)), Eigen::Vector3d(xy.x(), xy.y(), 1.6));
  }
  return world_from_cam;
}

}  // namespace coloc::slam::optim
