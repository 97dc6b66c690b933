#pragma once
// Loop correction (ORB-SLAM's CorrectLoop, in SE3): the new keyframe and its covisible
// neighbours take the verified pose (each keeps its pose relative to the new keyframe); the
// new keyframe's verified matches replace its own points, and the candidate group's points are
// fused into the corrected neighbourhood (duplicates merged); covisibility is recomputed on
// both sides and the connections that appeared are the loop connections; a loop edge joins the
// two keyframes; the essential graph spreads the correction over the whole map; each map point
// then moves with its reference keyframe.
//
// The caller holds the map lock and has paused local mapping.
#include <unordered_map>
#include <unordered_set>

#include "slam/loop/loop_options.hpp"
#include "slam/loop/verification.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::loop {

struct CorrectionReport {
  std::size_t corrected_neighbours = 0;  // keyframes moved with the new keyframe
  int replaced = 0;                      // the new keyframe's points merged with loop points
  int fused = 0;                         // duplicates fused in the neighbourhood
  std::size_t loop_connections = 0;      // new covisibility across the loop
  std::size_t graph_keyframes = 0, graph_edges = 0;
};

CorrectionReport correct_loop(map::Map& map, const LoopVerification& loop,
                              const LoopOptions& options);

// Moves every map point with its reference keyframe from `before` (cam_from_world per keyframe)
// to the keyframe's present pose; points whose reference is missing from `before`, and those in
// `skip`, stay.
void move_points_with_keyframes(map::Map& map, const std::unordered_map<KeyframeId, SE3>& before,
                                const std::unordered_set<MapPointId>& skip = {});

}  // namespace coloc::slam::loop
