#pragma once
// A window onto tracking for viewers (`coloc map --view`, `coloc localize --view`): after each
// frame, the tracking thread asks the observer whether it wants the frame and, only then, hands
// it a self-contained snapshot. The observer decides (throttles) and takes the snapshot without
// blocking: it must return at once, so a viewer, however slow or stuck, never slows tracking.
//
// Frames: world_from_cam in the map's frame, metres; keypoints in raw (distorted) image pixels,
// as the image shows them.
#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "slam/core/se3.hpp"
#include "slam/frame/frame.hpp"

namespace coloc::slam::system {

// The numbers are those of the OSC state (0 lost, 1 tracking, 2 just relocalized, 3 bridged by
// odometry) plus initializing, so a viewer shows one state whichever loop produced the frame.
enum class ObservedState : std::int32_t {
  kLost = 0,
  kTracking = 1,
  kRelocalized = 2,
  kOdometry = 3,
  kInit = 4
};
const char* to_string(ObservedState state);

struct FrameSnapshot {
  std::uint64_t index = 0;  // frames seen by the producer so far (0-based)
  double timestamp = 0.0;   // seconds
  ObservedState state = ObservedState::kInit;
  bool keyframe = false;  // this frame became a keyframe
  SE3 world_from_cam;     // valid for kTracking, kRelocalized and kOdometry
  int inliers = 0;
  double track_ms = 0.0;  // extraction + tracking of this frame
  // Keypoints of the frame (raw pixels) and whether each is tracked (matched, not an outlier).
  std::vector<Eigen::Vector2f> keypoints;
  std::vector<std::uint8_t> tracked;
  cv::Mat image;     // the image as tracking got it (a copy, owned by the snapshot)
  bool rgb = false;  // image channel order (true RGB, false BGR; grey either way)
};

// The keypoints of a tracked frame (empty `frame` when the frame was not tracked) into `out`.
void fill_keypoints(const frame::Frame& frame, FrameSnapshot& out);

class FrameObserver {
 public:
  virtual ~FrameObserver() = default;
  // Called in the tracking thread after every frame; cheap (no copy yet). True when the
  // observer wants this frame's snapshot (throttling lives here).
  virtual bool wants_frame(double timestamp) = 0;
  // Called in the tracking thread right after wants_frame() returned true. Must not block.
  virtual void on_frame(FrameSnapshot snapshot) = 0;
};

}  // namespace coloc::slam::system
