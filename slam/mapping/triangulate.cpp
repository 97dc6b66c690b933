#include "slam/mapping/triangulate.hpp"

#include <Eigen/SVD>
#include <cmath>

#include "slam/bow/matcher.hpp"

namespace coloc::slam::mapping {

namespace {

Eigen::Vector3d bearing(const frame::Frame& f, std::size_t i) {
  const auto& g = f.geometry();
  return {(f.features.keypoints[i].ux - g.cx) / g.fx, (f.features.keypoints[i].uy - g.cy) / g.fy,
          1.0};
}

// Linear (DLT) triangulation from normalized image coordinates and cam_from_world poses.
Eigen::Vector3d triangulate(const Eigen::Vector3d& x1, const SE3& p1, const Eigen::Vector3d& x2,
                            const SE3& p2) {
  const Eigen::Matrix<double, 3, 4> a = p1.matrix3x4(), b = p2.matrix3x4();
  Eigen::Matrix4d m;
  m.row(0) = x1.x() * a.row(2) - a.row(0);
  m.row(1) = x1.y() * a.row(2) - a.row(1);
  m.row(2) = x2.x() * b.row(2) - b.row(0);
  m.row(3) = x2.y() * b.row(2) - b.row(1);
  const Eigen::Vector4d h =
      Eigen::JacobiSVD<Eigen::Matrix4d>(m, Eigen::ComputeFullV).matrixV().col(3);
  return h.head<3>() / h(3);
}

// Reprojection chi2 test of a world point in one keyframe's keypoint.
bool reprojects(const frame::Frame& f, std::size_t i, const Eigen::Vector3d& world) {
  const auto& g = f.geometry();
  const Eigen::Vector3d pc = f.cam_from_world * world;
  if (pc.z() <= 0.0) return false;
  const Eigen::Vector2d uv = g.project(pc);
  const double inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(f.level(i))];
  double chi2 = (uv - f.pixel(i)).squaredNorm() * inv_sigma2;
  if (f.u_right[i] < 0.0f) return chi2 <= 5.991;
  const double er = uv.x() - g.bf / pc.z() - f.u_right[i];
  chi2 += er * er * inv_sigma2;
  return chi2 <= 7.8;
}

}  // namespace

std::vector<MapPointId> triangulate_with_neighbours(map::Map& m, KeyframeId id,
                                                    const std::vector<KeyframeId>& neighbours) {
  std::vector<MapPointId> created;
  for (KeyframeId nid : neighbours) {
    const map::Keyframe* k1 = m.keyframe(id);
    const map::Keyframe* k2 = m.keyframe(nid);
    if (!k1 || !k2 || k2->frame.feature_vector.entries.empty() ||
        k1->frame.feature_vector.entries.empty())
      continue;
    const frame::Frame& f1 = k1->frame;
    const frame::Frame& f2 = k2->frame;
    const auto& g = f1.geometry();
    // RGB-D: a baseline shorter than the virtual stereo one adds nothing to the depth.
    if ((k1->camera_centre() - k2->camera_centre()).norm() < g.bf / g.fx) continue;
    bow::BowMatchOptions options;
    options.max_distance = 50;
    options.ratio = 0.6;
    const auto matches =
        bow::match_by_bow(f1.features, f1.feature_vector, f2.features, f2.feature_vector, options);
    const Eigen::Matrix3d r1w = f1.cam_from_world.rotation().transpose();
    const Eigen::Matrix3d r2w = f2.cam_from_world.rotation().transpose();
    for (const auto& match : matches) {
      const std::size_t i1 = match.index_a, i2 = match.index_b;
      if (f1.points[i1].valid() || f2.points[i2].valid()) continue;
      // Both close with depth: the depth point is created by tracking, not here.
      const Eigen::Vector3d ray1 = r1w * bearing(f1, i1), ray2 = r2w * bearing(f2, i2);
      const double cos_rays = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
      double cos_stereo = 2.0;
      if (f1.has_depth(i1))
        cos_stereo = std::cos(2.0 * std::atan2(g.bf / g.fx / 2.0, f1.depth[i1]));
      if (f2.has_depth(i2))
        cos_stereo =
            std::min(cos_stereo, std::cos(2.0 * std::atan2(g.bf / g.fx / 2.0, f2.depth[i2])));
      Eigen::Vector3d world;
      if (cos_rays > 0.0 && cos_rays < cos_stereo && cos_rays < 0.9998) {
        world = triangulate(bearing(f1, i1), f1.cam_from_world, bearing(f2, i2), f2.cam_from_world);
      } else if (f1.has_depth(i1) && cos_stereo < 2.0) {
        world = f1.unproject_world(i1);
      } else if (f2.has_depth(i2) && cos_stereo < 2.0) {
        world = f2.unproject_world(i2);
      } else {
        continue;  // no parallax
      }
      if (!world.allFinite() || !reprojects(f1, i1, world) || !reprojects(f2, i2, world)) continue;
      const double d1 = (world - k1->camera_centre()).norm(),
                   d2 = (world - k2->camera_centre()).norm();
      if (d1 <= 0.0 || d2 <= 0.0) continue;
      const double ratio_dist = d2 / d1;
      const double ratio_octave = g.scale_factors[static_cast<std::size_t>(f1.level(i1))] /
                                  g.scale_factors[static_cast<std::size_t>(f2.level(i2))];
      const double factor = 1.5 * (g.scale_factors.size() > 1 ? g.scale_factors[1] : 1.2);
      if (ratio_dist * factor < ratio_octave || ratio_dist > ratio_octave * factor) continue;
      const MapPointId p = m.add_point(world, id, static_cast<std::uint32_t>(i1)).id;
      m.add_observation(p, nid, static_cast<std::uint32_t>(i2));
      m.update_point(p);
      created.push_back(p);
    }
  }
  return created;
}

}  // namespace coloc::slam::mapping
