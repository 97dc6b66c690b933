#include "slam/system/frame_observer.hpp"

namespace coloc::slam::system {

const char* to_string(ObservedState state) {
  switch (state) {
    case ObservedState::kLost:
      return "lost";
    case ObservedState::kTracking:
      return "tracking";
    case ObservedState::kRelocalized:
      return "relocalized";
    case ObservedState::kOdometry:
      return "odometry";
    case ObservedState::kInit:
      return "initializing";
  }
  return "unknown";
}

void fill_keypoints(const frame::Frame& frame, FrameSnapshot& out) {
  const std::size_t n = frame.size();
  out.keypoints.resize(n);
  out.tracked.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& k = frame.features.keypoints[i];
    out.keypoints[i] = {k.x, k.y};
    if (i < frame.points.size() && frame.points[i].valid() &&
        (i >= frame.outlier.size() || frame.outlier[i] == 0))
      out.tracked[i] = 1;
  }
}

}  // namespace coloc::slam::system
