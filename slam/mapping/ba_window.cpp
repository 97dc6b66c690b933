#include "slam/mapping/ba_window.hpp"

#include <unordered_map>

namespace coloc::slam::mapping {

BaWindow make_window(const map::Map& m, const std::vector<KeyframeId>& keyframes) {
  BaWindow w;
  if (keyframes.empty()) return w;
  const auto& g = m.keyframe(keyframes.front())->frame.geometry();
  w.intrinsics = {g.fx, g.fy, g.cx, g.cy, g.bf};
  std::unordered_map<KeyframeId, std::uint32_t> pose_index;
  auto add_pose = [&](KeyframeId k, bool fixed) {
    const auto index = static_cast<std::uint32_t>(w.pose_ids.size());
    pose_index.emplace(k, index);
    w.pose_ids.push_back(k);
    w.problem.poses.push_back({m.keyframe(k)->cam_from_world(), fixed});
    return index;
  };
  for (KeyframeId k : keyframes)
    add_pose(k, k == m.first_keyframe());
  std::unordered_map<MapPointId, std::uint32_t> point_index;
  for (KeyframeId k : keyframes) {
    for (MapPointId p : m.keyframe(k)->frame.points) {
      if (!p.valid() || point_index.count(p) || !m.point(p)) continue;
      point_index[p] = static_cast<std::uint32_t>(w.point_ids.size());
      w.point_ids.push_back(p);
      w.problem.points.push_back(m.point(p)->position);
    }
  }
  for (std::size_t pi = 0; pi < w.point_ids.size(); ++pi) {
    for (const auto& [k, idx] : m.point(w.point_ids[pi])->observations) {
      const map::Keyframe* kf = m.keyframe(k);
      if (!kf) continue;
      const auto it = pose_index.find(k);
      const std::uint32_t pose = it != pose_index.end() ? it->second : add_pose(k, true);
      const frame::Frame& f = kf->frame;
      optim::BundleProblem::Observation o;
      o.pose = pose;
      o.point = static_cast<std::uint32_t>(pi);
      o.pixel = f.pixel(idx);
      o.u_right = f.u_right[idx];
      o.inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(f.level(idx))];
      o.shear = f.shutter_shear(idx);
      w.problem.observations.push_back(o);
      w.observation_ids.emplace_back(w.point_ids[pi], k);
    }
  }
  return w;
}

void apply_window(map::Map& m, const BaWindow& w, const optim::BundleResult& result) {
  for (std::size_t i = 0; i < w.observation_ids.size(); ++i) {
    const auto& [point, keyframe] = w.observation_ids[i];
    if (result.outlier[i] && m.point(point) && m.keyframe(keyframe))
      m.erase_observation(point, keyframe);
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

}  // namespace coloc::slam::mapping
