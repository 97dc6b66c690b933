#pragma once
// The rolling-shutter readout estimated online (map::SharedMap::estimate_readout): what changes in
// the map when local mapping moves the estimate.
#include "slam/map/map.hpp"

namespace coloc::slam::mapping {

// Compensates every keyframe's keypoints again for `readout` (seconds; frame::Frame::
// set_shutter_readout) and moves each map point with its reference keyframe's keypoint, at the
// same depth (z): the point stays where that keyframe's keypoint and depth put it, so tracking and
// the next BA start from a consistent map instead of one whose points lag their keypoints.
// Keyframes without a recorded rate, and their points, stay. Call under the map lock.
void set_map_readout(map::Map& map, double readout);

}  // namespace coloc::slam::mapping
