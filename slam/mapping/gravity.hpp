#pragma once
// Gravity for the global BA from an accelerometer beside the camera (optim::BundleProblem::
// Gravity). Vision fixes the tilt only relative to the first keyframe, so it drifts as a random
// walk; an accelerometer measures it absolutely, but mixed with the camera's own acceleration.
// Per keyframe, over a window of +-half_window seconds around it:
//  - the mean specific force, each sample turned into the keyframe's camera frame by the gyro
//    (so the window may turn) and by the IMU-camera rotation, and moved to the camera's origin
//    (+ alpha x t + omega x (omega x t), t the lever arm): a 2 cm arm turning at 1.6 rad/s
//    adds 0.05 m/s^2 (5 mrad of tilt) at every corner. With the twin's noise-free IMU and true
//    poses the residual across gravity is 0.013 m/s^2 RMS without the arm, 0.0003 with it;
//  - the mean acceleration of the camera in the world frame, from the tracked trajectory: the
//    velocity change across the window, velocities by central differences over
//    +-velocity_half_window. Short ones: over +-0.2 s they smooth away a walker's step bounce
//    (~2 Hz) that the accelerometer still sees, and on the twin building the residuals' RMS
//    was 0.09 m/s^2 against 0.03 with +-0.05 s (ATE after the BA 7.3 -> 7.0 mm and 9.0 ->
//    8.1 mm on two maps). What is left is mostly the tracked positions' noise.
// A window the IMU samples or the trajectory do not cover (a lost stretch) gives no measurement.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "slam/core/imu_sample.hpp"
#include "slam/core/se3.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::mapping {

struct GravityOptions {
  double half_window = 0.5;            // seconds
  double velocity_half_window = 0.05;  // seconds
  double max_sample_gap = 0.05;        // seconds: a longer gap in the IMU log voids the window
  double max_frame_gap = 0.2;          // seconds: nor is a longer one in the trajectory bridged
  optim::BundleProblem::GravityModel model;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

class GravityMeasurements {
 public:
  // `imu`: the samples; `imu_from_cam`: the camera's pose in the IMU frame (ORB-SLAM3's
  // IMU.T_b_c1); `frames`: the tracked trajectory.
  GravityMeasurements(std::vector<ImuSample> imu, const SE3& imu_from_cam, Trajectory frames,
                      const GravityOptions& options = {});

  // The measurement of a keyframe taken at `timestamp` (its pose index left 0), or nothing.
  std::optional<optim::BundleProblem::Gravity> at(double timestamp) const;
  const GravityOptions& options() const { return options_; }

 private:
  std::optional<Eigen::Vector3d> position(double t) const;  // camera centre, world
  std::optional<Eigen::Vector3d> velocity(double t) const;
  std::optional<Eigen::Vector3d> mean_force(double t) const;  // IMU frame at t

  std::vector<ImuSample> imu_;  // accel moved to the camera's origin
  SO3 cam_from_imu_;
  Trajectory frames_;
  GravityOptions options_;
};

}  // namespace coloc::slam::mapping
