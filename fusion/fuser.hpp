#pragma once
// DriftFuser: the headset-mode fusion. Headset poses (xr_from_head, ~90 Hz) go in and come out
// as fused poses world_from_head = D * xr_from_head at the same rate; global poses
// (world_from_head from the localizer, 15-60 Hz, stamped at the camera's exposure time) update
// the filtered drift D (drift_filter.hpp).
//
// Beyond the paper: time alignment (pose_buffer.hpp), Mahalanobis gating, an optional rate limit
// on the applied correction, and an explicit state that says whether D is fresh or held.
//
// Clock: all times are seconds on one clock shared by headset and localizer (the caller maps
// clocks). Frames: "xr" = the headset's tracking frame, "world" = the scan's frame, "head" = the
// tracked device (the localizer's camera, already calibrated into the headset's frame).
// Thread-safety: none; one owner calls it (the OSC node and the C library wrap it in a mutex).

#include <cstdint>

#include "fusion/drift_filter.hpp"
#include "fusion/pose_buffer.hpp"
#include "slam/core/se3.hpp"

namespace coloc::fusion {

// Tracking state of a global pose, as sent on the wire (osc.hpp). kOdometry: the localizer is
// not localized in its map and carries its last pose on by visual odometry; such a pose drifts
// like the headset does, so it is no measurement of the headset's drift and is ignored like a
// lost one (counted apart).
enum class TrackingState : std::int32_t {
  kLost = 0,
  kTracking = 1,
  kRelocalized = 2,
  kOdometry = 3
};

// A state as numbered on the wire (osc.hpp, c_api.h). A number this build does not know (a
// newer sender) counts as tracking, as before kOdometry existed.
TrackingState tracking_state_from_wire(std::int32_t state);

// What the client can read about the correction it is getting.
enum class FusionState : std::int32_t {
  kWaiting = 0,   // no global pose yet: outputs are the raw headset poses
  kTracking = 1,  // D follows recent global poses
  kHolding = 2,   // no accepted global pose for hold_after seconds: D is held constant
};

struct FuserOptions {
  DriftFilterOptions filter;
  // Compare a global pose with the headset pose interpolated at its exposure time (true), or
  // with the newest headset pose (false, the paper's behaviour).
  bool time_alignment = true;
  double buffer_seconds = 2.0;      // headset history kept for alignment
  double max_extrapolation = 0.02;  // s: accept a global pose this much newer than the headset
  double hold_after = 0.5;          // s without an accepted global pose -> kHolding
  // After a gap in global poses the filter's process noise is applied once per missed period
  // (the period is learnt from the stream), so a drift that moved while holding is taken up
  // smoothly instead of being gated out; at most this many periods are counted.
  double max_gap_periods = 2000.0;
  // Rate limit of the correction as the user sees it (at the head); 0 disables each.
  double max_correction_speed = 0.0;  // m/s
  double max_correction_rate = 0.0;   // rad/s

  void check() const;
};

struct FuserStats {
  std::uint64_t xr_poses = 0;      // headset poses accepted
  std::uint64_t global_poses = 0;  // global poses received (all)
  std::uint64_t accepted = 0;      // global poses that updated D
  std::uint64_t initialized = 0;   // (re-)initializations of D
  std::uint64_t rejected = 0;      // gated out as improbable
  std::uint64_t lost = 0;          // global poses with TrackingState::kLost (ignored)
  std::uint64_t odometry = 0;      // global poses with TrackingState::kOdometry (ignored)
  std::uint64_t unaligned = 0;     // no headset pose at the global pose's time
  std::uint64_t out_of_order = 0;  // headset or global poses not newer than the previous one
};

struct FusedPose {
  double time = 0.0;  // the headset pose's time
  SE3 world_from_head;
  FusionState state = FusionState::kWaiting;
};

class DriftFuser {
 public:
  explicit DriftFuser(FuserOptions options = {});

  // A headset pose; returns the fused pose for it (the previous output if out of order).
  FusedPose push_xr_pose(double time, const SE3& xr_from_head);

  // A global pose stamped at its exposure time; returns what the gate decided (kRejected also
  // for poses that could not be used: lost, unaligned or out of order; see stats()).
  GateDecision push_global_pose(double time, const SE3& world_from_head,
                                TrackingState tracking = TrackingState::kTracking);

  // A sender's clock was re-anchored (restarted sender, stepped clock; stream_guard.hpp): forget
  // that stream's time history so messages on the new clock are taken. D is kept; after a
  // headset restart the state is holding until a global pose on the new clock is accepted.
  void restart_xr_clock();
  void restart_global_clock();

  const FusedPose& latest() const { return latest_; }
  FusionState state() const { return latest_.state; }
  const FuserStats& stats() const { return stats_; }
  const FuserOptions& options() const { return options_; }
  // Filtered drift (world_from_xr), and the drift applied to outputs (differs when rate-limited).
  SE3 filtered_drift() const { return estimate_.drift(); }
  const SE3& applied_drift() const { return applied_; }
  const DriftEstimate& estimate() const { return estimate_; }

 private:
  FuserOptions options_;
  PoseBuffer buffer_;
  DriftEstimate estimate_;
  SE3 applied_;
  FusedPose latest_;
  FuserStats stats_;
  bool have_xr_ = false;
  double last_global_time_ = -1e300;
  double last_accepted_time_ = -1e300;
  double global_period_ = 0.0;  // running mean of the accepted global poses' interval, s
};

// Moves the head pose `current` toward `target` by at most max_distance metres and max_angle
// radians (<= 0: unlimited). Pure; the rate limit's core.
SE3 step_toward(const SE3& current, const SE3& target, double max_distance, double max_angle);

}  // namespace coloc::fusion
