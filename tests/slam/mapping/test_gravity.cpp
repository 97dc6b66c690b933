// Gravity measurements for the global BA (mapping::GravityMeasurements) from an IMU log that
// turns and accelerates on an arm from the camera: the mean specific force in the keyframe's
// camera frame and the mean acceleration from the trajectory give gravity; windows the log or
// the trajectory do not cover give none.
#include <gtest/gtest.h>

#include "slam/core/error.hpp"
#include "slam/mapping/gravity.hpp"
#include "tests/slam/mapping/imu_mount.hpp"

namespace coloc::slam::mapping {
namespace {

// An IMU turning at a constant rate while accelerating at a constant rate in the world, with
// the camera on a 10 cm arm: the camera accelerates differently from the IMU.
struct Motion {
  Eigen::Vector3d omega{0.6, -1.2, 0.9};  // rad/s, IMU frame
  Eigen::Vector3d accel{0.3, -0.2, 0.1};  // m/s^2, world, of the IMU
  SO3 world_from_imu(double t) const { return SO3::exp({0.1, 0.2, -0.3}) * SO3::exp(omega * t); }
  Eigen::Vector3d imu_position(double t) const { return 0.5 * accel * t * t; }
};

using test::kImuFromCam;

std::vector<ImuSample> imu_log(const Motion& m, double from, double to, double skip_from = 1e9,
                               double skip_to = -1e9) {
  std::vector<ImuSample> log;
  for (double t = from; t <= to + 1e-9; t += 0.005) {
    if (t > skip_from && t < skip_to) continue;
    ImuSample s;
    s.timestamp = t;
    s.gyro = m.omega;
    s.accel = m.world_from_imu(t).inverse() * (m.accel + Eigen::Vector3d(0.0, 0.0, 9.81));
    log.push_back(s);
  }
  return log;
}

Trajectory frames(const Motion& m, double from, double to) {
  Trajectory t;
  for (double s = from; s <= to + 1e-9; s += 1.0 / 30.0) {
    const SE3 world_from_imu(m.world_from_imu(s), m.imu_position(s));
    t.push_back({s, world_from_imu * kImuFromCam});
  }
  return t;
}

TEST(GravityMeasurements, ForceAndAccelerationOfTheCameraGiveGravity) {
  const Motion m;
  const GravityMeasurements g(imu_log(m, 0.0, 4.0), kImuFromCam, frames(m, 0.0, 4.0));
  const auto at = g.at(2.0);
  ASSERT_TRUE(at);
  const SO3 world_from_cam = m.world_from_imu(2.0) * kImuFromCam.so3();
  // What the BA's residual is built on: turned into the world, force - acceleration = g up, the
  // lever arm's centripetal and tangential terms included (without them: 0.1 m/s^2 off here).
  const Eigen::Vector3d gravity = world_from_cam * at->specific_force_cam - at->accel_world;
  EXPECT_LT((gravity - Eigen::Vector3d(0.0, 0.0, 9.81)).norm(), 2e-3) << gravity.transpose();
  // The camera circles the IMU: its mean acceleration is not the IMU's.
  EXPECT_GT((at->accel_world - m.accel).norm(), 0.05);
}

TEST(GravityMeasurements, WindowsOutsideTheLogOrTheTrajectoryOrAcrossAGapGiveNone) {
  const Motion m;
  const GravityMeasurements g(imu_log(m, 0.0, 4.0, 2.9, 3.1), kImuFromCam, frames(m, 0.5, 4.0));
  EXPECT_TRUE(g.at(1.5));
  EXPECT_FALSE(g.at(0.3));  // before the trajectory
  EXPECT_FALSE(g.at(3.0));  // a 0.2 s hole in the IMU log
  EXPECT_FALSE(g.at(3.8));  // after the log's end
  EXPECT_FALSE(g.at(10.0));
  // Tracking lost for 0.3 s where the window's first velocity is taken.
  Trajectory lost = frames(m, 0.0, 4.0);
  std::erase_if(lost,
                [](const StampedPose& p) { return p.timestamp > 1.35 && p.timestamp < 1.65; });
  const GravityMeasurements h(imu_log(m, 0.0, 4.0), kImuFromCam, lost);
  EXPECT_FALSE(h.at(2.0));
  EXPECT_TRUE(h.at(2.5));
}

TEST(GravityMeasurements, OptionsAreChecked) {
  GravityOptions o;
  o.half_window = 0.0;
  EXPECT_THROW(GravityMeasurements({}, SE3(), {}, o), Error);
  o = {};
  o.model.sigma = -1.0;
  EXPECT_THROW(o.check(), Error);
}

}  // namespace
}  // namespace coloc::slam::mapping
