#pragma once
// What an IMU beside the camera measured at a keyframe, as the map keeps it: slam/mapping
// computes it from a recording's log (mapping::record_inertial), the global BA reads it from
// the map, slam/mapdb stores it. A continued map is adjusted long after the log of the recording
// that made its first keyframes is gone; without these its loaded keyframes would be held by
// vision alone while the new ones had the IMU too.
#include <Eigen/Core>

#include "slam/core/ids.hpp"
#include "slam/core/so3.hpp"

namespace coloc::slam::map {

// The keyframe's gravity window (mapping/gravity.hpp; optim::BundleProblem::Gravity).
struct GravityWindow {
  // The id of the first keyframe of the recording that measured it: keyframes of one
  // recording share an accelerometer bias, those of another have their own.
  KeyframeId recording;
  Eigen::Vector3d specific_force_cam = Eigen::Vector3d::Zero();  // m/s^2
  Eigen::Vector3d accel_world = Eigen::Vector3d::Zero();         // m/s^2
};

// The gyro's rotation from the keyframe to the next one of its recording in time
// (mapping/gyro.hpp; optim::BundleProblem::Gyro).
struct GyroLink {
  KeyframeId recording;  // as in GravityWindow
  KeyframeId next;
  SO3 cam_from_next;                                        // integrated at zero bias
  Eigen::Matrix3d bias_jacobian = Eigen::Matrix3d::Zero();  // of its log, rad per rad/s
  double dt = 0.0;                                          // seconds integrated
};

// The link a -> c through b (b erased): rotations composed, and the bias Jacobian carried
// through the second rotation, since exp(J_ab db) R_bc = R_bc exp(R_bc^T J_ab db).
GyroLink chain(const GyroLink& a_to_b, const GyroLink& b_to_c);

}  // namespace coloc::slam::map
