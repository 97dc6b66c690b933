#pragma once
// Duplicate fusion (ORB-SLAM's ORBmatcher::Fuse): projects map points into a keyframe; where a
// keypoint matches (descriptor <= 50, reprojection chi2 under 7.8/5.99 at its level) and
// already has a point, the two points are merged (the one with more observations survives),
// otherwise the keypoint becomes a new observation. Caller holds the map lock.
#include <vector>

#include "slam/map/map.hpp"

namespace coloc::slam::matching {

// Returns the number of fused or added observations.
int fuse_points(map::Map& map, KeyframeId keyframe, const std::vector<MapPointId>& points,
                double radius_px);

}  // namespace coloc::slam::matching
