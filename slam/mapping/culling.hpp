#pragma once
// What decides whether local mapping culls a keyframe (LocalMapper::cull_keyframes), as free
// functions on the map so tests can check each part on a map they build.
#include "slam/map/map.hpp"

namespace coloc::slam::mapping {

// Of k's close points (RGB-D: those with a reliable depth), the share seen by at least three
// other keyframes at the same or a finer scale (one pyramid level of slack): ORB-SLAM's measure
// of a redundant keyframe. 0 when k has no close point.
double redundant_share(const map::Map& m, KeyframeId k);

// Degrees between the optical axes of two keyframes.
double axis_angle_deg(const map::Keyframe& a, const map::Keyframe& b);

// Whether k's covisible neighbours just before and just after it (by id, so in time) both look
// within `max_deg` of its direction: k lies inside a stretch its neighbours cover.
bool between_same_view(const map::Map& m, KeyframeId k, double max_deg);

// Whether every marker k sees is seen by at least `min_others` other keyframes. Registration
// ties the map to the scan through these views: culling must not take a marker's last ones.
bool markers_seen_elsewhere(const map::Map& m, KeyframeId k, int min_others = 2);

}  // namespace coloc::slam::mapping
