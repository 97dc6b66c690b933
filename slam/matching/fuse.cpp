#include "slam/matching/fuse.hpp"

#include <algorithm>
#include <cmath>

#include "slam/matching/search.hpp"

namespace coloc::slam::matching {

int fuse_points(map::Map& map, KeyframeId keyframe_id, const std::vector<MapPointId>& points,
                double radius_px) {
  int n = 0;
  for (MapPointId id : points) {
    map::Keyframe* kf = map.keyframe(keyframe_id);
    const map::MapPoint* p = map.point(id);
    if (!kf || !p || p->observations.count(keyframe_id)) continue;
    const frame::Frame& f = kf->frame;
    const auto& g = f.geometry();
    const Eigen::Vector3d pc = f.cam_from_world * p->position;
    if (pc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = g.project(pc);
    if (!g.in_bounds(uv)) continue;
    const Eigen::Vector3d ray = p->position - f.camera_centre();
    const double dist = ray.norm();
    if (dist < 0.8 * p->min_distance || dist > 1.2 * p->max_distance) continue;
    if (ray.dot(p->normal) < 0.5 * dist) continue;
    const int level = p->predict_level(dist, g);
    const double r = radius_px * g.scale_factors[static_cast<std::size_t>(level)];
    const double ur = uv.x() - g.bf / pc.z();
    int best = 256;
    std::size_t best_idx = 0;
    for (std::size_t j : f.features_in_area(uv.x(), uv.y(), r, std::max(0, level - 1), level)) {
      const double inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(f.level(j))];
      const Eigen::Vector2d e = f.pixel(j) - uv;
      double chi2 = e.squaredNorm() * inv_sigma2;
      double th = 5.99;
      if (f.u_right[j] >= 0.0f) {
        const double er = f.u_right[j] - ur;
        chi2 += er * er * inv_sigma2;
        th = 7.8;
      }
      if (chi2 > th) continue;
      const int d = features::hamming_distance(p->descriptor, f.features.descriptors[j]);
      if (d < best) {
        best = d;
        best_idx = j;
      }
    }
    if (best > kDescriptorLow) continue;
    const MapPointId existing = f.points[best_idx];
    if (existing.valid() && map.point(existing)) {
      map.replace_point(id, existing);
    } else {
      map.add_observation(id, keyframe_id, static_cast<std::uint32_t>(best_idx));
    }
    ++n;
  }
  return n;
}

}  // namespace coloc::slam::matching
