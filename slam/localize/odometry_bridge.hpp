#pragma once
// Visual odometry from an anchor frame that carries a localizer across views its map does not cover
// (ORB-SLAM2's localization mode does the same with "visual odometry" points). A user walks
// where the survey did not go, or looks at a table from its other side: the map has no points
// there and relocalization finds no keyframe, yet the frames still see the same surfaces as the
// frame before. The bridge keeps an anchor frame's keypoints that have a close depth as 3-D
// points (world frame, from the anchor's pose), finds them in each following frame by
// projection and descriptor, and solves its pose. The anchor is the last frame localized in the
// map, and moves to a bridged frame only when too few of its points are still found (as a
// keyframe would): moving it at every frame adds one frame's pose error per frame. The points
// never enter the map, which stays read-only.
//
// A bridged pose drifts: each new anchor adds the error of one pose from one frame's depth. So the
// bridge stops after `max_frames` in a row and its poses carry their own state (kOdometry):
// a drift filter must not treat them as global measurements (fusion/fuser.hpp ignores them).
// The tracker keeps trying to relocalize in the map on every bridged frame, and the first frame
// it localizes ends the bridge.
//
// Frames: poses are cam_from_world in the map's frame; the anchor's keypoints are undistorted
// level-0 pixels with depth in metres (slam/frame/frame.hpp).
#include <optional>
#include <vector>

#include "slam/core/se3.hpp"
#include "slam/features/descriptor.hpp"
#include "slam/frame/frame.hpp"

namespace coloc::slam::localize {

struct OdometryBridgeOptions {
  // Bridged frames in a row before the bridge gives up and the localizer reports lost: 150
  // frames = 5 s at 30 Hz, a user looking away from the mapped part for a moment. Measured drift
  // from the bridge's start: the twin room walk 8 mm after 30 frames; 7-Scenes (colour and depth
  // not registered) 107 mm at most over 84 frames and 79 mm over 134 (0.8-0.9 m of path;
  // docs/results/surface-ba.md). 0 turns the bridge off.
  int max_frames = 150;
  int min_inliers = 30;  // points supporting a bridged pose (the localizer's own floor)
  // A bridged frame becomes the anchor when its inliers fall below this share of the first
  // frame's tracked from the current anchor. (An anchor moved at every frame: 39 mm after the
  // twin's 30 frames; 7-Scenes 60 mm after 84, where the depth misregistration favours short
  // baselines.)
  double reanchor_ratio = 0.6;
  double search_radius_px = 15;       // level-0 pixels around the predicted projection (x scale)
  int max_descriptor_distance = 100;  // Hamming (ORB-SLAM's TH_HIGH)
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct OdometryPose {
  SE3 cam_from_world;
  int inliers = 0;
  int bridged_frames = 0;  // this one included: 1 for the first frame after the map was lost
};

class OdometryBridge {
 public:
  explicit OdometryBridge(OdometryBridgeOptions options = {});

  // A frame whose pose is trusted (localized in the map): the bridge restarts from it.
  void anchor(const frame::Frame& frame, const SE3& cam_from_world);
  // Forget everything (a jump: the next bridge needs a new anchor).
  void reset();
  bool has_anchor() const { return !points_.empty(); }

  // Tracks `frame` (features and depth, no pose needed) from the anchor, predicted by the last
  // two poses' motion. Returns nullopt when there is no anchor, the bridge has run max_frames
  // already, or too few points support a pose (the bridge then ends).
  std::optional<OdometryPose> track(const frame::Frame& frame);

 private:
  struct Point {
    Eigen::Vector3d world;
    features::Descriptor descriptor;
    int level = 0;
  };
  // Matches the anchor's points to `frame`'s keypoints around their projections from
  // `cam_from_world`; returns (point index, keypoint index) pairs, one per keypoint.
  std::vector<std::pair<std::size_t, std::size_t>> match(const frame::Frame& frame,
                                                         const SE3& cam_from_world,
                                                         double radius_px) const;
  void set_anchor(const frame::Frame& frame, const SE3& cam_from_world);
  void set_last(const SE3& cam_from_world);

  OdometryBridgeOptions options_;
  std::vector<Point> points_;  // the anchor's
  int anchor_inliers_ = 0;     // of the first frame tracked from the anchor (0: none yet)
  SE3 last_cam_from_world_;    // the last pose, localized or bridged
  SE3 velocity_;               // cam_from_world(k) * cam_from_world(k-1)^-1 of the last two
  bool has_last_ = false, has_velocity_ = false;
  int bridged_ = 0;
};

}  // namespace coloc::slam::localize
