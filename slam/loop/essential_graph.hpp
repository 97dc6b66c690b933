#pragma once
// Essential-graph optimization (ORB-SLAM's OptimizeEssentialGraph, in SE3: RGB-D has no scale
// drift): a Ceres pose graph over every keyframe with the spanning tree, the loop edges, the
// strong covisibility edges (weight >= strong_covisibility) and the new loop connections. An
// edge's measurement is the relative pose before the correction (what odometry and local BA
// established), except for new loop connections, measured with the corrected poses (what the
// loop established). Residual: log of meas^-1 * (a * b^-1), translation (metres) then rotation
// (radians), unit weights.
//
// The caller holds the map lock.
#include <unordered_map>
#include <utility>
#include <vector>

#include "slam/map/map.hpp"

namespace coloc::slam::loop {

struct EssentialGraphInput {
  // Poses before the correction (the uncorrected measurements); a keyframe missing here is
  // measured with its current pose.
  std::unordered_map<KeyframeId, SE3> original;
  // New loop connections (measured with the current, corrected poses).
  std::vector<std::pair<KeyframeId, KeyframeId>> loop_connections;
  KeyframeId fixed;  // held in place (the loop's old side)
  int strong_covisibility = 100;
  int iterations = 20;
};

struct EssentialGraphReport {
  std::size_t keyframes = 0, edges = 0;
  double initial_cost = 0.0, final_cost = 0.0;
};

// Optimizes every keyframe pose of `map` in place, starting from the current poses.
EssentialGraphReport optimize_essential_graph(map::Map& map, const EssentialGraphInput& input);

}  // namespace coloc::slam::loop
