#pragma once
// Recorded (or simulated) streams replayed through the fusers in arrival order: what `coloc fuse
// --xr/--imu ... --global` does with files, and how the simulated sessions of the tests and
// `coloc bench fusion` are fused. A global pose is stamped at its exposure and handed to the
// fuser once its arrival time has come, before the headset or IMU sample of that time.

#include <vector>

#include "fusion/fuser.hpp"
#include "fusion/imu.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::fusion {

// A global pose (world_from_head, or world_from_body in IMU mode) on its way to the fuser.
struct GlobalSample {
  double exposure_time = 0.0;  // stamp of the pose
  double arrival_time = 0.0;   // when it reaches the fuser
  SE3 world_from_head;
  bool outlier = false;  // known only in simulations
};

// The poses of a recorded trajectory (stamped at exposure, same clock as the headset or IMU)
// arriving `latency` seconds after their stamps.
std::vector<GlobalSample> delayed(const Trajectory& world_from_head, double latency);

struct HeadsetReplay {
  Trajectory fused;  // world_from_head, one per headset pose
  FuserStats stats;
};

// Headset poses (xr_from_head, time-ordered) with the global poses of `global` (arrival order).
HeadsetReplay replay_headset(const Trajectory& xr_from_head,
                             const std::vector<GlobalSample>& global, const FuserOptions& options);
// The same into a given fuser (e.g. to warm it up before timing it); returns the fused poses.
Trajectory replay_headset(const Trajectory& xr_from_head, const std::vector<GlobalSample>& global,
                          DriftFuser& fuser);

struct ImuReplay {
  Trajectory fused;  // world_from_body, one per IMU sample once anchored and not waiting
  ImuFuserStats imu;
  FuserStats fuser;
};

// IMU mode: IMU samples (time-ordered) with global world_from_body poses (arrival order).
ImuReplay replay_imu(const std::vector<ImuSample>& imu, const std::vector<GlobalSample>& global,
                     const ImuFuserOptions& options);

}  // namespace coloc::fusion
