#pragma once
// A short history of headset poses, so a global pose stamped at the camera's exposure time can
// be compared with the headset pose at exactly that time (time alignment). Without it the
// localizer's latency (tens of ms) shows up as false drift whenever the head moves.
//
// Not thread-safe: owned by one fuser, which serializes access.

#include <cstddef>
#include <deque>
#include <optional>

#include "slam/core/se3.hpp"

namespace coloc::fusion {

struct StampedSE3 {
  double time = 0.0;  // seconds, on the clock shared by headset and localizer
  SE3 pose;
};

class PoseBuffer {
 public:
  // Keeps poses of the last `window_seconds` (and at most max_size of them).
  explicit PoseBuffer(double window_seconds = 2.0, std::size_t max_size = 1024);

  // Appends a pose; returns false (and ignores it) when time is not after the newest pose.
  bool push(double time, const SE3& pose);

  // Pose at `time`: slerp/lerp between the two bracketing samples. A time after the newest
  // sample is answered with the newest pose when within max_extrapolation seconds (the headset
  // sample for that instant may not have arrived yet). std::nullopt when outside the buffer.
  std::optional<SE3> at(double time, double max_extrapolation = 0.0) const;

  std::optional<StampedSE3> newest() const;
  std::size_t size() const { return poses_.size(); }
  void clear() { poses_.clear(); }

 private:
  double window_seconds_;
  std::size_t max_size_;
  std::deque<StampedSE3> poses_;
};

}  // namespace coloc::fusion
