#pragma once
// IMU mode (paper section 5.3): no headset. The camera's own IMU (100-200 Hz) is integrated into
// a 6-DoF pose odom_from_body between global poses, and that pose's drift is corrected exactly
// as the headset's: D = world_from_body * inverse(odom_from_body), filtered (drift_filter.hpp).
//
// Frames: "body" = the IMU; "odom" = the integration frame, gravity-aligned (z up, gravity
// (0, 0, -9.81) m/s^2 by default); "world" = the scan. Global poses must be world_from_body (a
// localizer's world_from_cam times cam_from_body). Units: s, rad/s, m/s^2, m.
//
// Gravity and bias handling: a static start initializes roll/pitch from the accelerometer's
// gravity direction and the gyroscope bias from its mean. The first global pose re-anchors the
// integration in the world frame (gravity is carried along, so a scan that is not levelled
// still works). From then on each accepted, time-aligned global pose feeds back into the
// integrator like a complementary filter: position, velocity and accelerometer bias through a
// critically damped third-order loop (bandwidth position_bandwidth), rotation and gyroscope bias
// through a second-order loop (rotation_bandwidth). That keeps the integrated pose from running
// away (double integration turns a 0.1 m/s^2 error into metres within seconds); the drift
// filter then removes what is left, exactly as in headset mode, and gates bad global poses.

#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include "fusion/fuser.hpp"
#include "fusion/pose_buffer.hpp"
#include "slam/core/se3.hpp"

namespace coloc::fusion {

struct ImuSample {
  double time = 0.0;                                // s
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, body frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, specific force, body frame
};

// The integrated state. Value type; the functions below return new states.
struct ImuState {
  double time = 0.0;
  SO3 odom_from_body;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // of body in odom, m
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  // in odom, m/s
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();

  SE3 pose() const { return SE3(odom_from_body, position); }
};

// Reads an IMU log in the EuRoC/ASL CSV layout ("t[ns],wx,wy,wz,ax,ay,az", '#' header), as
// EuRoC's imu0/data.csv and our recorder's imu.txt. Throws coloc::Error naming file and line.
std::vector<ImuSample> read_imu_csv(const std::filesystem::path& path);

// Static initialization from samples at rest: gyro bias = mean gyro; rotation with zero yaw
// whose gravity direction matches the mean accelerometer reading. nullopt when the samples do
// not look static (mean accelerometer norm off gravity by > 0.5 m/s^2, or gyro standard
// deviation > 0.1 rad/s).
std::optional<ImuState> initialize_static(std::span<const ImuSample> samples,
                                          const Eigen::Vector3d& gravity);

// One integration step from a to b (midpoint rule on bias-corrected readings).
ImuState propagate(const ImuState& state, const ImuSample& a, const ImuSample& b,
                   const Eigen::Vector3d& gravity);

struct ImuFuserOptions {
  FuserOptions fuser;  // the drift filter on odom_from_body
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};
  double static_init_seconds = 0.5;  // samples collected for initialize_static
  double position_bandwidth = 1.0;   // rad/s of the position/velocity/accel-bias loop
  double rotation_bandwidth = 1.0;   // rad/s of the rotation/gyro-bias loop
  double max_gap = 0.1;              // s: larger IMU gaps are not integrated across (counted)

  void check() const;
};

struct ImuFuserStats {
  std::uint64_t imu_samples = 0;
  std::uint64_t corrections = 0;   // global poses fed back into the integrator
  std::uint64_t gaps = 0;          // IMU gaps longer than max_gap
  std::uint64_t out_of_order = 0;  // IMU samples not newer than the previous one
};

// IMU integration + drift filter. Thread-safety: none (one owner).
class ImuFuser {
 public:
  explicit ImuFuser(ImuFuserOptions options = {});

  // Starts from a known state instead of a static initialization. With in_world = true the
  // state is already in the world frame (and `gravity` is the world's), so no re-anchoring.
  void initialize(const ImuState& state, bool in_world = false);
  bool initialized() const { return initialized_; }
  bool anchored() const { return anchored_; }  // integrating in the world frame

  // Integrates one sample; returns the fused world_from_body (kWaiting before initialization).
  FusedPose push_imu(const ImuSample& sample);
  GateDecision push_global_pose(double time, const SE3& world_from_body,
                                TrackingState tracking = TrackingState::kTracking);

  const ImuState& state() const { return state_; }
  const Eigen::Vector3d& gravity() const { return gravity_; }
  const DriftFuser& fuser() const { return fuser_; }
  const ImuFuserStats& stats() const { return stats_; }

 private:
  ImuFuserOptions options_;
  DriftFuser fuser_;
  ImuState state_;
  ImuSample last_;
  bool have_last_ = false;
  bool initialized_ = false;
  std::vector<ImuSample> init_samples_;
  void anchor(const SE3& world_from_odom);
  void feed_back(double time, const SE3& world_from_body, const SE3& integrated);

  Eigen::Vector3d gravity_;  // in the integration frame (odom until anchored, then world)
  bool anchored_ = false;
  double last_correction_ = 0.0;
  PoseBuffer integrated_;  // recent integrated poses, for time alignment of the feedback
  ImuFuserStats stats_;
};

}  // namespace coloc::fusion
