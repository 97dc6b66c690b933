#pragma once
// A bundle-adjustment problem copied out of the map, and its write-back: shared by the local BA
// (a keyframe and its covisible neighbours) and the global BA (every keyframe). Keyframes that
// observe the window's points but are not in the window enter as fixed poses; the map's first
// keyframe is always fixed (it defines the world frame).
//
// Threads: make_window() and apply_window() need the map lock; bundle_adjust() on the window
// runs without it.
#include <utility>
#include <vector>

#include "slam/map/map.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::mapping {

struct BaWindow {
  optim::BundleProblem problem;
  optim::Intrinsics intrinsics;
  std::vector<KeyframeId> pose_ids;   // problem.poses[i] is keyframe pose_ids[i]
  std::vector<MapPointId> point_ids;  // problem.points[i] is point point_ids[i]
  std::vector<std::pair<MapPointId, KeyframeId>> observation_ids;  // per observation
};

// `keyframes`: the poses to optimize (the first is the window's reference; all must exist).
BaWindow make_window(const map::Map& map, const std::vector<KeyframeId>& keyframes);

// Writes optimized poses and points back, erasing the observations BA classified as outliers.
// Keyframes or points erased meanwhile (by the other thread) are skipped.
void apply_window(map::Map& map, const BaWindow& window, const optim::BundleResult& result);

}  // namespace coloc::slam::mapping
