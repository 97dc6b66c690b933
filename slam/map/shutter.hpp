#pragma once
// Rolling-shutter compensation of keyframes that are already in the map (frame/rolling_shutter.hpp
// for one frame): what changes in the map when a keyframe's compensation changes afterwards.
#include <Eigen/Core>

#include "slam/map/map.hpp"

namespace coloc::slam::map {

// Compensates every keyframe's keypoints again for `readout` (seconds; frame::Frame::
// set_shutter_readout; local mapping moved its online estimate) and moves each map point with its
// reference keyframe's keypoint, at the same depth (z): the point stays where that keyframe's
// keypoint and depth put it, so tracking and the next BA start from a consistent map instead of
// one whose points lag their keypoints. Keyframes without a recorded rate, and their points,
// stay. Call under the map lock.
void set_map_readout(Map& map, double readout);

// Gives keyframe `id`, made without a rotation rate (the first keyframe of a map has no tracked
// frame before it), the rate `rate_cam` (rad/s, camera frame) and compensates it for `readout`
// (seconds; rows as frame::Frame::compensate_rolling_shutter), moving its points as above. A
// keyframe that already has a rate is left as it is. Call under the map lock.
void set_keyframe_shutter_rate(Map& map, KeyframeId id, const Eigen::Vector3d& rate_cam,
                               int image_rows, double readout);

}  // namespace coloc::slam::map
