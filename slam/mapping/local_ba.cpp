// LocalMapper's bundle adjustment and keyframe culling (split from local_mapper.cpp for size).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <unordered_map>

#include "slam/core/timing.hpp"
#include "slam/mapping/local_mapper.hpp"

namespace coloc::slam::mapping {

namespace {

// The window as copied out of the map, with the ids needed to write it back.
struct Window {
  optim::BundleProblem problem;
  std::vector<KeyframeId> pose_ids;
  std::vector<MapPointId> point_ids;
  std::vector<std::pair<MapPointId, KeyframeId>> observation_ids;
  optim::Intrinsics intrinsics;
};

Window build_window(const map::Map& m, KeyframeId current) {
  Window w;
  const map::Keyframe* kf = m.keyframe(current);
  const auto& g = kf->frame.geometry();
  w.intrinsics = {g.fx, g.fy, g.cx, g.cy, g.bf};
  std::vector<KeyframeId> local{current};
  for (KeyframeId k : m.covisible(current))
    local.push_back(k);
  std::unordered_map<KeyframeId, std::uint32_t> pose_index;
  for (KeyframeId k : local) {
    pose_index[k] = static_cast<std::uint32_t>(w.pose_ids.size());
    w.pose_ids.push_back(k);
    // The first keyframe fixes the gauge (ORB-SLAM fixes keyframe 0 when it is in the window).
    w.problem.poses.push_back({m.keyframe(k)->cam_from_world(), k == m.first_keyframe()});
  }
  std::unordered_map<MapPointId, std::uint32_t> point_index;
  for (KeyframeId k : local) {
    for (MapPointId p : m.keyframe(k)->frame.points) {
      if (!p.valid() || point_index.count(p) || !m.point(p)) continue;
      point_index[p] = static_cast<std::uint32_t>(w.point_ids.size());
      w.point_ids.push_back(p);
      w.problem.points.push_back(m.point(p)->position);
    }
  }
  for (std::size_t pi = 0; pi < w.point_ids.size(); ++pi) {
    for (const auto& [k, idx] : m.point(w.point_ids[pi])->observations) {
      const map::Keyframe* okf = m.keyframe(k);
      if (!okf) continue;
      auto it = pose_index.find(k);
      if (it == pose_index.end()) {  // a keyframe outside the window: fixed
        it = pose_index.emplace(k, static_cast<std::uint32_t>(w.pose_ids.size())).first;
        w.pose_ids.push_back(k);
        w.problem.poses.push_back({okf->cam_from_world(), true});
      }
      const frame::Frame& f = okf->frame;
      optim::BundleProblem::Observation o;
      o.pose = it->second;
      o.point = static_cast<std::uint32_t>(pi);
      o.pixel = f.pixel(idx);
      o.u_right = f.u_right[idx];
      o.inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(f.level(idx))];
      w.problem.observations.push_back(o);
      w.observation_ids.emplace_back(w.point_ids[pi], k);
    }
  }
  return w;
}

}  // namespace

void LocalMapper::local_bundle_adjustment(KeyframeId current) {
  Window w;
  {
    std::lock_guard lock(shared_.mutex);
    if (!shared_.map.keyframe(current) || shared_.map.keyframe_count() < 2) return;
    w = build_window(shared_.map, current);
  }
  Stopwatch watch;
  const optim::BundleResult result =
      optim::bundle_adjust(w.problem, w.intrinsics, options_.ba, &abort_ba_);
  const double ms = watch.elapsed_ms();
  {
    std::lock_guard lock(shared_.mutex);
    map::Map& m = shared_.map;
    for (std::size_t i = 0; i < w.observation_ids.size(); ++i) {
      if (result.outlier[i])
        m.erase_observation(w.observation_ids[i].first, w.observation_ids[i].second);
    }
    for (std::size_t i = 0; i < w.pose_ids.size(); ++i) {
      if (w.problem.poses[i].fixed) continue;
      if (map::Keyframe* kf = m.keyframe(w.pose_ids[i]))
        kf->frame.cam_from_world = w.problem.poses[i].cam_from_world;
    }
    for (std::size_t i = 0; i < w.point_ids.size(); ++i) {
      if (map::MapPoint* p = m.point(w.point_ids[i])) {
        p->position = w.problem.points[i];
        m.update_point(p->id);
      }
    }
  }
  std::lock_guard slock(state_mutex_);
  ++stats_.ba_runs;
  stats_.ba_aborted += result.aborted ? 1 : 0;
  stats_.ba_ms.push_back(ms);
}

void LocalMapper::cull_keyframes(KeyframeId current) {
  std::lock_guard lock(shared_.mutex);
  map::Map& m = shared_.map;
  if (!m.keyframe(current)) return;
  int culled = 0;
  for (KeyframeId k : m.covisible(current)) {
    const map::Keyframe* kf = m.keyframe(k);
    if (!kf || k == m.first_keyframe()) continue;
    const frame::Frame& f = kf->frame;
    int total = 0, redundant = 0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      const map::MapPoint* p = f.points[i].valid() ? m.point(f.points[i]) : nullptr;
      // RGB-D: only close points count (far ones are weakly constrained anyway).
      if (!p || !f.is_close(i)) continue;
      ++total;
      if (m.weighted_observations(p->id) <= 3) continue;
      int seen = 0;
      for (const auto& [ok, oidx] : p->observations) {
        if (ok == k) continue;
        const map::Keyframe* other = m.keyframe(ok);
        if (other && other->frame.level(oidx) <= f.level(i) + 1 && ++seen >= 3) break;
      }
      redundant += seen >= 3 ? 1 : 0;
    }
    if (total > 0 && redundant > options_.redundancy * total) {
      shared_.database.erase(k.value());
      m.erase_keyframe(k);
      ++culled;
    }
  }
  std::lock_guard slock(state_mutex_);
  stats_.keyframes_culled += culled;
}

}  // namespace coloc::slam::mapping
