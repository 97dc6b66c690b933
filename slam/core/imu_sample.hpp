#pragma once
// One reading of an inertial measurement unit, as datasets record them and gravity-aided
// optimization (slam/mapping/gravity.hpp) consumes them.
#include <Eigen/Core>

namespace coloc {

struct ImuSample {
  double timestamp = 0.0;                           // seconds
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, sensor frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, sensor frame (includes gravity)
};

}  // namespace coloc
