#pragma once
// Motion of the twin's sensors: a person walking the floor plan's path with a head-mounted
// RGB-D camera (looking around, head bob), the camera's IMU, and an XR headset on the same
// head whose tracking drifts. All functions are deterministic in their seed.
//
// Frames: world = scan frame (z up, metres). cam: x right, y down, z forward. imu: rigidly
// attached to cam (imu_from_cam). headset: rigidly attached to cam (cam_from_headset); the
// headset reports poses in its own drifting "xr" frame.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <vector>

#include "slam/core/se3.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::registration::twin {

struct WalkOptions {
  double speed = 1.0;             // m/s along the path (approximately; a C2 B-spline)
  double head_height = 1.6;       // metres above the floor
  double bob_amplitude = 0.015;   // metres, vertical head bob at the step frequency
  double step_frequency = 1.8;    // Hz
  double look_amplitude = 0.55;   // radians of yaw oscillation around the walking direction
  double look_period = 6.5;       // seconds
  double pitch_amplitude = 0.15;  // radians
  double start_time = 1000.0;     // seconds: timestamp of the first pose

  void check() const;
};

// A smooth (C2 position, smooth orientation) walk along a polyline.
class WalkTrajectory {
 public:
  WalkTrajectory(const std::vector<Eigen::Vector2d>& path, const WalkOptions& options,
                 std::uint64_t seed);
  double start_time() const { return options_.start_time; }
  double end_time() const { return options_.start_time + duration_; }
  // world_from_cam at time t (seconds, clamped to [start_time, end_time]).
  SE3 world_from_cam(double t) const;

 private:
  Eigen::Vector2d spline(double u) const;  // u in knot units, clamped
  std::vector<Eigen::Vector2d> control_;
  WalkOptions options_;
  double duration_ = 0.0;
  double knot_dt_ = 1.0;
  double start_heading_ = 0.0;  // radians: the direction the walk sets off in
  std::array<double, 4> phase_{};
};

// Samples world_from_cam(t) at rate Hz from t0 to t1 (inclusive of t0).
Trajectory sample_trajectory(const WalkTrajectory& walk, double rate, double t0, double t1);

struct ImuOptions {
  double rate = 200.0;                  // Hz
  double gyro_noise_density = 2.4e-4;   // rad/s/sqrt(Hz)   (BMI055-like, as in the D455)
  double accel_noise_density = 1.8e-3;  // m/s^2/sqrt(Hz)
  double gyro_random_walk = 2.0e-5;     // rad/s^2/sqrt(Hz)
  double accel_random_walk = 3.0e-4;    // m/s^3/sqrt(Hz)
  double initial_gyro_bias = 0.003;     // rad/s, standard deviation per axis
  double initial_accel_bias = 0.05;     // m/s^2, standard deviation per axis
  double gravity = 9.81;                // m/s^2, along -z of the world
  SE3 imu_from_cam = SE3(SO3(), Eigen::Vector3d(-0.0203, 0.0051, 0.0112));

  void check() const;
};

struct ImuSample {
  double timestamp = 0.0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, imu frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, specific force, imu frame
};

struct ImuTruth {
  ImuSample ideal;  // noise- and bias-free
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
};

// IMU measurements consistent with the walk: angular rate and specific force of the imu frame
// from central differences of the exact pose function, plus white noise and random-walk biases.
void simulate_imu(const WalkTrajectory& walk, const ImuOptions& options, std::uint64_t seed,
                  std::vector<ImuSample>& measured, std::vector<ImuTruth>& truth);

struct HeadsetOptions {
  double rate = 90.0;                // Hz
  double translation_drift = 0.004;  // m/sqrt(s), random walk of the xr origin
  double yaw_drift = 0.0015;         // rad/sqrt(s), random walk of the xr heading
  double jitter = 0.0004;            // m, white position noise per pose
  SE3 cam_from_headset =
      SE3(SO3::exp(Eigen::Vector3d(0.02, -0.03, 0.01)), Eigen::Vector3d(0.01, -0.09, -0.06));
  void check() const;
};

struct HeadsetStreams {
  Trajectory xr_from_headset;     // what the headset reports (drifting)
  Trajectory world_from_headset;  // truth
  Trajectory world_from_xr;       // the drift: true xr origin at every sample
};

HeadsetStreams simulate_headset(const WalkTrajectory& walk, const HeadsetOptions& options,
                                std::uint64_t seed);

}  // namespace coloc::registration::twin
