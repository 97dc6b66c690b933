#pragma once
// The IMU mount of the gravity and gyro tests: turned and offset on every axis, so no term of
// the extrinsic can hide behind a zero.
#include "slam/core/se3.hpp"

namespace coloc::slam::mapping::test {

inline const SE3 kImuFromCam(SO3::exp({0.5, -0.2, 1.0}), Eigen::Vector3d(0.06, -0.05, 0.06));

}  // namespace coloc::slam::mapping::test
