#include "fusion/fuser.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "slam/core/error.hpp"

namespace coloc::fusion {

void FuserOptions::check() const {
  filter.check();
  const auto require = [](bool ok, const char* field, const char* what) {
    if (!ok) throw Error(what, ErrorContext{.field = std::string("FuserOptions.") + field});
  };
  require(buffer_seconds > 0.0, "buffer_seconds", "must be positive");
  require(max_extrapolation >= 0.0, "max_extrapolation", "must not be negative");
  require(hold_after > 0.0, "hold_after", "must be positive");
  require(max_gap_periods >= 1.0, "max_gap_periods", "must be at least 1");
  require(max_correction_speed >= 0.0, "max_correction_speed", "must not be negative (0 = off)");
  require(max_correction_rate >= 0.0, "max_correction_rate", "must not be negative (0 = off)");
}

SE3 step_toward(const SE3& current, const SE3& target, double max_distance, double max_angle) {
  Eigen::Vector3d delta = target.translation() - current.translation();
  if (max_distance > 0.0 && delta.norm() > max_distance) delta *= max_distance / delta.norm();
  const double angle = angular_distance(current.so3(), target.so3());
  double fraction = 1.0;
  if (max_angle > 0.0 && angle > max_angle) fraction = max_angle / angle;
  return SE3(interpolate(current.so3(), target.so3(), fraction), current.translation() + delta);
}

DriftFuser::DriftFuser(FuserOptions options) : options_(options), buffer_(options_.buffer_seconds) {
  options_.check();
}

FusedPose DriftFuser::push_xr_pose(double time, const SE3& xr_from_head) {
  if (have_xr_ && !(time > latest_.time)) {
    ++stats_.out_of_order;
    return latest_;
  }
  const double dt = have_xr_ ? time - latest_.time : 0.0;
  have_xr_ = true;
  ++stats_.xr_poses;
  buffer_.push(time, xr_from_head);

  FusionState state = FusionState::kWaiting;
  if (estimate_.initialized) {
    state = time - last_accepted_time_ > options_.hold_after ? FusionState::kHolding
                                                             : FusionState::kTracking;
    const SE3 target = estimate_.drift();
    if (options_.max_correction_speed > 0.0 || options_.max_correction_rate > 0.0) {
      // Limit the correction where the user sees it: at the head, not at D's origin (a small
      // rotation of D moves a head 10 m from the origin by 10 m * angle).
      const SE3 head_now = applied_ * xr_from_head;
      const SE3 head_target = target * xr_from_head;
      const SE3 head = step_toward(head_now, head_target, options_.max_correction_speed * dt,
                                   options_.max_correction_rate * dt);
      applied_ = head * xr_from_head.inverse();
    } else {
      applied_ = target;
    }
  }
  latest_ = {time, applied_ * xr_from_head, state};
  return latest_;
}

void DriftFuser::restart_xr_clock() {
  buffer_.clear();
  have_xr_ = false;
  last_accepted_time_ = -1e300;
}

void DriftFuser::restart_global_clock() {
  last_global_time_ = -1e300;
  last_accepted_time_ = -1e300;
}

TrackingState tracking_state_from_wire(std::int32_t state) {
  switch (state) {
    case 0:
      return TrackingState::kLost;
    case 2:
      return TrackingState::kRelocalized;
    case 3:
      return TrackingState::kOdometry;
    default:
      return TrackingState::kTracking;
  }
}

GateDecision DriftFuser::push_global_pose(double time, const SE3& world_from_head,
                                          TrackingState tracking) {
  ++stats_.global_poses;
  if (tracking == TrackingState::kLost) {
    ++stats_.lost;
    return GateDecision::kRejected;
  }
  if (tracking == TrackingState::kOdometry) {
    ++stats_.odometry;
    return GateDecision::kRejected;
  }
  if (!(time > last_global_time_)) {
    ++stats_.out_of_order;
    return GateDecision::kRejected;
  }
  std::optional<SE3> xr_from_head;
  if (options_.time_alignment) {
    xr_from_head = buffer_.at(time, options_.max_extrapolation);
  } else if (const auto newest = buffer_.newest()) {
    xr_from_head = newest->pose;
  }
  if (!xr_from_head) {
    ++stats_.unaligned;
    return GateDecision::kRejected;
  }
  last_global_time_ = time;
  const bool first = !estimate_.initialized;
  // Periods since the last accepted pose: 1 while the stream flows, more after a gap.
  double steps = 1.0;
  if (estimate_.initialized && global_period_ > 0.0) {
    steps =
        std::clamp((time - last_accepted_time_) / global_period_, 1.0, options_.max_gap_periods);
  }
  const DriftUpdate update = update_drift(estimate_, measure_drift(world_from_head, *xr_from_head),
                                          options_.filter, steps, xr_from_head->translation());
  estimate_ = update.estimate;
  switch (update.decision) {
    case GateDecision::kRejected:
      ++stats_.rejected;
      return update.decision;
    case GateDecision::kInitialized:
      ++stats_.initialized;
      // The first D is applied at once (there is nothing to be smooth with yet).
      if (first) applied_ = estimate_.drift();
      break;
    case GateDecision::kAccepted:
      ++stats_.accepted;
      break;
  }
  if (update.decision == GateDecision::kAccepted) {
    // Learn the period from uninterrupted intervals only (a gap would inflate it).
    const double interval = time - last_accepted_time_;
    if (interval > 0.0 && interval < options_.hold_after) {
      global_period_ = global_period_ > 0.0 ? 0.9 * global_period_ + 0.1 * interval : interval;
    }
  }
  last_accepted_time_ = std::max(last_accepted_time_, time);
  return update.decision;
}

}  // namespace coloc::fusion
