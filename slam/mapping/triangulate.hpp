#pragma once
// New map points from a keyframe and its covisible neighbours (ORB-SLAM's CreateNewMapPoints):
// keypoints without a point in either keyframe are matched through the vocabulary's direct
// index, triangulated (linear, two views; or from depth when the depth gives the better
// parallax), and kept only when in front of both cameras, within the chi2 gates (5.991
// monocular, 7.8 stereo-like) in both, and at scale-consistent distances. Caller holds the map
// lock. Returns the ids of the new points.
#include <vector>

#include "slam/map/map.hpp"

namespace coloc::slam::mapping {

std::vector<MapPointId> triangulate_with_neighbours(map::Map& map, KeyframeId keyframe,
                                                    const std::vector<KeyframeId>& neighbours);

}  // namespace coloc::slam::mapping
