#include "slam/loop/correction.hpp"

#include <set>

#include "slam/loop/essential_graph.hpp"
#include "slam/matching/fuse.hpp"

namespace coloc::slam::loop {
namespace {

// The verified matches replace the new keyframe's own points (the old side is the reference).
int replace_matches(map::Map& map, const LoopVerification& loop) {
  int n = 0;
  for (std::size_t i = 0; i < loop.matches.size(); ++i) {
    const MapPointId old_point = loop.matches[i];
    const map::Keyframe* kf = map.keyframe(loop.current);
    if (!kf || !old_point.valid() || !map.point(old_point)) continue;
    const MapPointId own = kf->frame.points[i];
    if (own == old_point) continue;
    if (own.valid() && map.point(own)) {
      map.replace_point(own, old_point);
    } else {
      map.add_observation(old_point, loop.current, static_cast<std::uint32_t>(i));
    }
    ++n;
  }
  return n;
}

std::vector<MapPointId> group_points(const map::Map& map, KeyframeId centre, std::size_t n) {
  std::vector<KeyframeId> group{centre};
  for (KeyframeId k : map.covisible(centre, n))
    group.push_back(k);
  std::set<MapPointId> seen;
  std::vector<MapPointId> out;
  for (KeyframeId k : group)
    for (MapPointId p : map.keyframe(k)->frame.points)
      if (p.valid() && seen.insert(p).second) out.push_back(p);
  return out;
}

}  // namespace

void move_points_with_keyframes(map::Map& map, const std::unordered_map<KeyframeId, SE3>& before,
                                const std::unordered_set<MapPointId>& skip) {
  std::vector<MapPointId> ids;
  for (const auto& [id, p] : map.points())
    if (!skip.count(id)) ids.push_back(id);
  for (MapPointId id : ids) {
    map::MapPoint* p = map.point(id);
    const map::Keyframe* ref = map.keyframe(p->reference);
    const auto it = before.find(p->reference);
    if (!ref || it == before.end()) continue;
    p->position = ref->cam_from_world().inverse() * (it->second * p->position);
    map.update_point(id);
  }
}

CorrectionReport correct_loop(map::Map& map, const LoopVerification& loop,
                              const LoopOptions& options) {
  CorrectionReport report;
  std::unordered_map<KeyframeId, SE3> original;
  for (const auto& [id, kf] : map.keyframes())
    original.emplace(id, kf.cam_from_world());
  // The new keyframe's neighbourhood moves rigidly with it.
  const SE3 world_from_cur = original.at(loop.current).inverse();
  std::vector<KeyframeId> group{loop.current};
  for (KeyframeId k : map.covisible(loop.current))
    group.push_back(k);
  const std::set<KeyframeId> in_group(group.begin(), group.end());
  for (KeyframeId k : group)
    map.keyframe(k)->frame.cam_from_world =
        original.at(k) * world_from_cur * loop.corrected_cam_from_world;
  report.corrected_neighbours = group.size() - 1;
  // The group's points stay where they are until the end (they move with their reference
  // keyframes): the fusion projects the old side's points, which need no move.
  std::unordered_map<KeyframeId, std::set<KeyframeId>> before;
  for (KeyframeId k : group) {
    const auto c = map.covisible(k);
    before[k] = std::set<KeyframeId>(c.begin(), c.end());
  }
  report.replaced = replace_matches(map, loop);
  const std::vector<MapPointId> loop_points =
      group_points(map, loop.candidate, options.group_neighbours);
  for (KeyframeId k : group)
    if (map.keyframe(k))
      report.fused += matching::fuse_points(map, k, loop_points, options.fusion_radius_px);
  // Connections that appeared across the loop are its new edges.
  EssentialGraphInput graph;
  graph.original = original;
  for (KeyframeId k : group) {
    if (!map.keyframe(k)) continue;
    map.update_connections(k);
    for (KeyframeId n : map.covisible(k)) {
      if (in_group.count(n) || before[k].count(n)) continue;
      graph.loop_connections.emplace_back(k, n);
    }
  }
  graph.loop_connections.emplace_back(loop.current, loop.candidate);
  report.loop_connections = graph.loop_connections.size();
  map.keyframe(loop.current)->loop_edges.insert(loop.candidate);
  map.keyframe(loop.candidate)->loop_edges.insert(loop.current);
  // Odometry edges are measured with the uncorrected poses, so the graph spreads the correction
  // along the path instead of concentrating it at the group's border.
  graph.fixed = loop.candidate;
  graph.strong_covisibility = options.strong_covisibility;
  graph.iterations = options.graph_iterations;
  const EssentialGraphReport g = optimize_essential_graph(map, graph);
  report.graph_keyframes = g.keyframes;
  report.graph_edges = g.edges;
  move_points_with_keyframes(map, original);
  return report;
}

}  // namespace coloc::slam::loop
