// Gyro rotations between keyframes for the global BA (mapping::GyroMeasurements): the rotation
// integrated from an IMU log that turns at a changing rate, carried into the camera frame; its
// first-order change with the bias against integrating a biased log; intervals the log does not
// cover, or covers with a hole, give none.
#include <gtest/gtest.h>

#include "slam/core/error.hpp"
#include "slam/mapping/gyro.hpp"
#include "tests/slam/mapping/imu_mount.hpp"

namespace coloc::slam::mapping {
namespace {

using test::kImuFromCam;

// A rate that changes over time, sampled at 200 Hz with `bias` added (IMU frame).
Eigen::Vector3d rate(double t) {
  return {0.6 * std::sin(2.0 * t), -1.2 + 0.3 * t, 0.9 * std::cos(t)};
}

std::vector<ImuSample> imu_log(double from, double to, const Eigen::Vector3d& bias = {0, 0, 0},
                               double skip_from = 1e9, double skip_to = -1e9) {
  std::vector<ImuSample> log;
  for (double t = from; t <= to + 1e-9; t += 0.005) {
    if (t > skip_from && t < skip_to) continue;
    log.push_back({t, rate(t) + bias, Eigen::Vector3d(0.0, 0.0, 9.81)});
  }
  return log;
}

// The true rotation imu(t_a)_from_imu(t_b), integrated finely (midpoint rule).
SO3 true_turn(double t_a, double t_b) {
  SO3 r;
  const int steps = 20000;
  const double h = (t_b - t_a) / steps;
  for (int i = 0; i < steps; ++i)
    r = r * SO3::exp(rate(t_a + (i + 0.5) * h) * h);
  return r;
}

TEST(GyroMeasurements, RotationBetweenKeyframesInTheCameraFrame) {
  const GyroMeasurements gyro(imu_log(0.0, 4.0), kImuFromCam);
  const auto g = gyro.between(1.003, 1.41);
  ASSERT_TRUE(g);
  EXPECT_NEAR(g->dt, 0.407, 1e-12);
  const SO3 expected = kImuFromCam.so3().inverse() * true_turn(1.003, 1.41) * kImuFromCam.so3();
  // Rates linear between samples: the curvature's error only (holding each sample's rate for
  // its 5 ms was 1.3 mrad off here).
  EXPECT_LT(angular_distance(g->cam_a_from_cam_b, expected), 1e-5);
}

TEST(GyroMeasurements, BiasJacobianPredictsTheBiasedIntegral) {
  const Eigen::Vector3d bias_imu(0.01, -0.02, 0.015);
  const GyroMeasurements clean(imu_log(0.0, 4.0), kImuFromCam);
  const GyroMeasurements biased(imu_log(0.0, 4.0, bias_imu), kImuFromCam);
  const auto a = clean.between(0.5, 1.3);
  const auto b = biased.between(0.5, 1.3);
  ASSERT_TRUE(a && b);
  // The biased log, corrected by a bias b, integrates to measured * exp(J * b): with b the true
  // bias (camera frame) that is the clean log's rotation, to second order in the bias.
  const Eigen::Vector3d bias_cam = kImuFromCam.so3().inverse() * bias_imu;
  const SO3 predicted = b->cam_a_from_cam_b * SO3::exp(b->bias_jacobian * bias_cam);
  const double change = angular_distance(a->cam_a_from_cam_b, b->cam_a_from_cam_b);
  EXPECT_GT(change, 0.01);  // the bias matters over 0.8 s
  EXPECT_LT(angular_distance(predicted, a->cam_a_from_cam_b), 0.02 * change);
}

TEST(GyroMeasurements, IntervalsTheLogDoesNotCoverGiveNone) {
  const GyroMeasurements gyro(imu_log(0.5, 4.0, {0, 0, 0}, 2.0, 2.2), kImuFromCam);
  EXPECT_FALSE(gyro.between(0.2, 1.0));  // before the log
  EXPECT_FALSE(gyro.between(3.5, 4.5));  // after it
  EXPECT_FALSE(gyro.between(1.8, 2.5));  // across the hole
  EXPECT_FALSE(gyro.between(1.0, 1.0));  // empty
  EXPECT_FALSE(gyro.between(1.2, 1.0));  // backwards
  EXPECT_TRUE(gyro.between(2.3, 3.9));
  GyroOptions short_intervals;
  short_intervals.max_interval = 1.0;
  const GyroMeasurements bounded(imu_log(0.0, 4.0), kImuFromCam, short_intervals);
  EXPECT_FALSE(bounded.between(0.5, 1.6));
  EXPECT_TRUE(bounded.between(0.5, 1.4));
}

TEST(GyroMeasurements, OptionsAreChecked) {
  GyroOptions o;
  o.model.noise_density = 0.0;
  EXPECT_THROW(GyroMeasurements({}, SE3(), o), Error);
  o = {};
  o.max_interval = -1.0;
  EXPECT_THROW(GyroMeasurements({}, SE3(), o), Error);
}

}  // namespace
}  // namespace coloc::slam::mapping
