// Gravity measurements for the global BA (mapping::GravityMeasurements) from an IMU log that
// turns and accelerates: the mean specific force in the keyframe's camera frame and the mean
// acceleration from the trajectory; windows the log or the trajectory do not cover give none.
#include <gtest/gtest.h>

#include "slam/core/error.hpp"
#include "slam/mapping/gravity.hpp"

namespace coloc::slam::mapping {
namespace {

// A body turning at a constant rate while accelerating at a constant rate in the world.
struct Motion {
  Eigen::Vector3d omega{0.2, -0.4, 0.3};  // rad/s, body frame
  Eigen::Vector3d accel{0.3, -0.2, 0.1};  // m/s^2, world
  SO3 world_from_body(double t) const { return SO3::exp({0.1, 0.2, -0.3}) * SO3::exp(omega * t); }
  Eigen::Vector3d position(double t) const { return 0.5 * accel * t * t; }
};

const SO3 kImuFromCam = SO3::exp({0.5, -0.2, 1.0});

std::vector<ImuSample> imu_log(const Motion& m, double from, double to, double skip_from = 1e9,
                               double skip_to = -1e9) {
  std::vector<ImuSample> log;
  for (double t = from; t <= to + 1e-9; t += 0.005) {
    if (t > skip_from && t < skip_to) continue;
    ImuSample s;
    s.timestamp = t;
    s.gyro = m.omega;
    s.accel = m.world_from_body(t).inverse() * (m.accel + Eigen::Vector3d(0.0, 0.0, 9.81));
    log.push_back(s);
  }
  return log;
}

Trajectory frames(const Motion& m, double from, double to) {
  Trajectory t;
  for (double s = from; s <= to + 1e-9; s += 1.0 / 30.0)
    t.push_back({s, SE3(m.world_from_body(s) * kImuFromCam, m.position(s))});
  return t;
}

TEST(GravityMeasurements, MeanForceInTheCameraAndMeanAccelerationInTheWorld) {
  const Motion m;
  const GravityMeasurements g(imu_log(m, 0.0, 4.0), kImuFromCam.inverse().matrix(),
                              frames(m, 0.0, 4.0));
  const auto at = g.at(2.0);
  ASSERT_TRUE(at);
  const SO3 world_from_cam = m.world_from_body(2.0) * kImuFromCam;
  const Eigen::Vector3d expected =
      world_from_cam.inverse() * (m.accel + Eigen::Vector3d(0.0, 0.0, 9.81));
  EXPECT_LT((at->specific_force_cam - expected).norm(), 2e-3) << at->specific_force_cam.transpose();
  EXPECT_LT((at->accel_world - m.accel).norm(), 1e-6) << at->accel_world.transpose();
  // What the BA's residual is built on: turned into the world, force - acceleration = g up.
  const Eigen::Vector3d up = world_from_cam * at->specific_force_cam - at->accel_world;
  EXPECT_NEAR(up.normalized().z(), 1.0, 1e-6);
}

TEST(GravityMeasurements, WindowsOutsideTheLogOrTheTrajectoryOrAcrossAGapGiveNone) {
  const Motion m;
  const GravityMeasurements g(imu_log(m, 0.0, 4.0, 2.9, 3.1), kImuFromCam.inverse().matrix(),
                              frames(m, 0.5, 4.0));
  EXPECT_TRUE(g.at(1.5));
  EXPECT_FALSE(g.at(0.3));  // before the trajectory
  EXPECT_FALSE(g.at(3.0));  // a 0.2 s hole in the IMU log
  EXPECT_FALSE(g.at(3.8));  // after the log's end
  EXPECT_FALSE(g.at(10.0));
}

TEST(GravityMeasurements, OptionsAreChecked) {
  GravityOptions o;
  o.half_window = 0.0;
  EXPECT_THROW(GravityMeasurements({}, Eigen::Matrix3d::Identity(), {}, o), Error);
  o = {};
  o.model.sigma = -1.0;
  EXPECT_THROW(o.check(), Error);
}

}  // namespace
}  // namespace coloc::slam::mapping
