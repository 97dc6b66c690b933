#include "registration/align/transform.hpp"

#include <cmath>
#include <unordered_map>

namespace coloc::registration::align {

namespace {

SE3 moved_pose(const SE3& cam_from_world, const Sim3& t) {
  const SE3 world_from_cam = cam_from_world.inverse();
  const SE3 moved(t.so3() * world_from_cam.so3(), t * world_from_cam.translation());
  return moved.inverse();
}

void scale_depths(slam::frame::Frame& f, double s) {
  const double bf = f.geometry_ptr() ? f.geometry().bf : 0.0;
  for (std::size_t i = 0; i < f.depth.size(); ++i) {
    if (!(f.depth[i] > 0.0f)) continue;
    f.depth[i] = static_cast<float>(f.depth[i] * s);
    if (i < f.u_right.size() && f.u_right[i] >= 0.0f)
      f.u_right[i] = static_cast<float>(f.features.keypoints[i].ux - bf / f.depth[i]);
  }
}

// The stored depth image too (millimetres; a depth scaled beyond what u16 holds becomes none).
void scale_depths(slam::map::KeyframeDepth& d, double s) {
  for (std::uint16_t& mm : d.millimetres) {
    if (mm == 0) continue;
    const double scaled = std::round(mm * s);
    mm = scaled >= 1.0 && scaled <= 65535.0 ? static_cast<std::uint16_t>(scaled) : 0;
  }
}

}  // namespace

void transform_map(slam::map::Map& map, const Sim3& t) {
  const double s = t.scale();
  if (std::abs(s - 1.0) < 1e-12) {
    std::vector<KeyframeId> ids;
    for (const auto& [id, kf] : map.keyframes())
      ids.push_back(id);
    for (KeyframeId id : ids) {
      slam::map::Keyframe* kf = map.keyframe(id);
      kf->frame.cam_from_world = moved_pose(kf->frame.cam_from_world, t);
    }
    std::vector<MapPointId> points;
    for (const auto& [id, p] : map.points())
      points.push_back(id);
    for (MapPointId id : points) {
      slam::map::MapPoint* p = map.point(id);
      p->position = t * p->position;
      p->normal = t.so3() * p->normal;
    }
    return;
  }
  // Scaled: rebuild, since the erased chain is only reachable through restore().
  std::unordered_map<KeyframeId, slam::map::Keyframe> keyframes = map.keyframes();
  std::unordered_map<MapPointId, slam::map::MapPoint> points = map.points();
  slam::map::MapBookkeeping book = map.bookkeeping();
  for (auto& [id, kf] : keyframes) {
    kf.frame.cam_from_world = moved_pose(kf.frame.cam_from_world, t);
    scale_depths(kf.frame, s);
    if (kf.depth) scale_depths(*kf.depth, s);
  }
  for (auto& [id, p] : points) {
    p.position = t * p.position;
    p.normal = t.so3() * p.normal;
    p.min_distance *= s;
    p.max_distance *= s;
  }
  for (auto& [id, e] : book.erased)
    e.cam_from_parent.translation() *= s;
  map = slam::map::Map::restore(std::move(keyframes), std::move(points), std::move(book));
}

}  // namespace coloc::registration::align
