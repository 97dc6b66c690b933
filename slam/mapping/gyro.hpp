#pragma once
// Gyro rotations between keyframes for the global BA (optim::BundleProblem::Gyro). Vision fixes
// the heading only relative to where it saw the same things; on the twin building, after the
// loop is closed, what remains of the error is horizontal and comes from heading errors of a
// few mrad, made at corners where the view sweeps. The gyro measures those turns to a tenth of
// a mrad. Per pair of keyframes, the samples between them are integrated at zero bias (the rate
// linear between samples) with the first-order change of the result with the bias (Forster et
// al., "On-Manifold Preintegration", 2017: the rotation part), then carried into the camera
// frame by the IMU-camera rotation.
#include <optional>
#include <vector>

#include "slam/core/imu_sample.hpp"
#include "slam/core/se3.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::mapping {

struct GyroOptions {
  double max_sample_gap = 0.05;  // seconds: a longer gap in the IMU log voids the interval
  double max_interval = 10.0;    // seconds: keyframes further apart get no Gyro
  optim::BundleProblem::GyroModel model;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

class GyroMeasurements {
 public:
  // `imu`: the samples; `imu_from_cam`: the camera's pose in the IMU frame (IMU.T_b_c1).
  GyroMeasurements(std::vector<ImuSample> imu, const SE3& imu_from_cam,
                   const GyroOptions& options = {});

  // The rotation from time t_a to t_b > t_a (pose indices left 0), or nothing when the log
  // does not cover the interval without a gap or the interval is too long.
  std::optional<optim::BundleProblem::Gyro> between(double t_a, double t_b) const;
  const GyroOptions& options() const { return options_; }

 private:
  std::vector<ImuSample> imu_;
  SO3 cam_from_imu_;
  GyroOptions options_;
};

}  // namespace coloc::slam::mapping
