#include "registration/align/slam_markers.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "markers/marker_pose.hpp"
#include "markers/sighting_fusion.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {

namespace {

// One keyframe's view of one marker: its pose and the corners' undistorted pixels.
struct View {
  KeyframeId keyframe;
  SE3 cam_from_world;
  std::array<Eigen::Vector2d, 4> pixels{};
};

struct Pinhole {
  double fx, fy, cx, cy;
  // Projection and d pixel / d p_cam of a camera-frame point with z > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& p, Eigen::Matrix<double, 2, 3>* jac) const {
    const double iz = 1.0 / p.z();
    if (jac) {
      *jac << fx * iz, 0.0, -fx * p.x() * iz * iz,  //
          0.0, fy * iz, -fy * p.y() * iz * iz;
    }
    return {fx * p.x() * iz + cx, fy * p.y() * iz + cy};
  }
};

Pinhole pinhole_of(const Camera& camera) {
  const Eigen::Matrix3d k = intrinsic_matrix(camera);
  return {k(0, 0), k(1, 1), k(0, 2), k(1, 2)};
}

// RMS over the 4 corners of one view (pixels); infinity when a corner is behind the camera.
double view_rms(const Pinhole& k, const View& v, const std::array<Eigen::Vector3d, 4>& corners) {
  double sum = 0.0;
  for (int c = 0; c < 4; ++c) {
    const Eigen::Vector3d p = v.cam_from_world * corners[c];
    if (p.z() <= 1e-6) return std::numeric_limits<double>::infinity();
    sum += (v.pixels[c] - k.project(p, nullptr)).squaredNorm();
  }
  return std::sqrt(sum / 4.0);
}

// Gauss-Newton on one corner with Huber weights (delta 2 px). False when the normal matrix is
// degenerate (too little parallax) or a view puts the corner behind its camera.
bool triangulate_corner(const Pinhole& k, const std::vector<const View*>& views, int corner,
                        int iterations, Eigen::Vector3d& x) {
  constexpr double kHuber = 2.0;
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (const View* v : views) {
      const Eigen::Vector3d p = v->cam_from_world * x;
      if (p.z() <= 1e-6) return false;
      Eigen::Matrix<double, 2, 3> jp;
      const Eigen::Vector2d r = v->pixels[static_cast<std::size_t>(corner)] - k.project(p, &jp);
      const Eigen::Matrix<double, 2, 3> j = jp * v->cam_from_world.rotation();
      const double n = r.norm();
      const double w = n <= kHuber ? 1.0 : kHuber / n;
      h += w * j.transpose() * j;
      b += w * j.transpose() * r;
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(h);
    if (!(eig.eigenvalues()(0) > 1e-9 * eig.eigenvalues()(2)) || !(eig.eigenvalues()(0) > 0.0))
      return false;
    const Eigen::Vector3d step = h.ldlt().solve(b);
    x += step;
    if (step.norm() < 1e-7) break;
  }
  return true;
}

// Triangulates the four corners from the views, dropping views whose RMS exceeds the gate,
// starting from the fused corners. False (marker left as fused) when fewer than two views stay
// or the geometry is degenerate.
bool triangulate_marker(const Pinhole& k, const std::vector<View>& views,
                        const SlamMarkerOptions& o, SlamMarker& m) {
  std::vector<const View*> kept;
  for (const View& v : views) {
    if (view_rms(k, v, m.corners) <= 4.0 * o.max_reprojection_px) kept.push_back(&v);
  }
  std::array<Eigen::Vector3d, 4> corners = m.corners;
  for (int round = 0; round < 3; ++round) {
    if (kept.size() < 2) return false;
    for (int c = 0; c < 4; ++c) {
      if (!triangulate_corner(k, kept, c, o.triangulation_iterations, corners[c])) return false;
    }
    std::vector<const View*> next;
    for (const View* v : kept) {
      if (view_rms(k, *v, corners) <= o.max_reprojection_px) next.push_back(v);
    }
    if (next.size() == kept.size()) break;
    kept = std::move(next);
  }
  if (kept.size() < 2) return false;
  double sum = 0.0;
  for (const View* v : kept)
    sum += std::pow(view_rms(k, *v, corners), 2);
  m.corners = corners;
  m.reprojection_rms_px = std::sqrt(sum / static_cast<double>(kept.size()));
  m.triangulated = true;
  return true;
}

}  // namespace

void SlamMarkerOptions::check() const {
  if (!(marker_size >= 0.0)) throw Error("must be >= 0 (metres)", {.field = "marker_size"});
  if (!(max_distance > 0.0)) throw Error("must be positive (metres)", {.field = "max_distance"});
  if (!(max_pose_error_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "max_pose_error_px"});
  if (!(fusion_min_gate > 0.0))
    throw Error("must be positive (metres)", {.field = "fusion_min_gate"});
  if (!(fusion_mad_factor > 0.0)) throw Error("must be positive", {.field = "fusion_mad_factor"});
  if (triangulation_iterations < 0)
    throw Error("must be >= 0", {.field = "triangulation_iterations"});
  if (!(max_reprojection_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "max_reprojection_px"});
}

Eigen::Vector3d SlamMarker::centre() const {
  return 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
}

SlamMarkers slam_marker_corners(const slam::map::Map& map, const Camera& camera,
                                const SlamMarkerOptions& o) {
  o.check();
  const Pinhole k = pinhole_of(camera);
  std::vector<KeyframeId> ids;
  for (const auto& [id, kf] : map.keyframes())
    ids.push_back(id);
  std::sort(ids.begin(), ids.end());

  SlamMarkers out;
  std::map<int, std::vector<markers::Sighting>> sightings;
  std::map<int, std::vector<View>> views;
  std::map<int, std::vector<KeyframeId>> seen_in;
  for (KeyframeId id : ids) {
    const slam::map::Keyframe& kf = *map.keyframe(id);
    if (kf.markers.empty()) continue;
    const double size = kf.marker_size > 0.0 ? kf.marker_size : o.marker_size;
    if (!(size > 0.0)) {
      throw Error("keyframe " + std::to_string(id.value()) +
                      " has markers but no edge length; give the marker size",
                  {.field = "marker_size"});
    }
    const SE3 world_from_cam = kf.cam_from_world().inverse();
    for (const markers::MarkerObservation& obs : kf.markers) {
      seen_in[obs.id].push_back(id);
      View view{id, kf.cam_from_world(), {}};
      bool pixels_ok = true;
      for (int c = 0; c < 4; ++c) {
        view.pixels[c] = undistort_pixel(camera, obs.corners[c]);
        pixels_ok = pixels_ok && view.pixels[c].allFinite();
      }
      if (pixels_ok) views[obs.id].push_back(view);
      const auto pose = markers::estimate_marker_pose(camera, obs, {.marker_size = size});
      if (!pixels_ok || !pose || pose->reprojection_error_px() > o.max_pose_error_px ||
          pose->distance() > o.max_distance) {
        ++out.unusable_observations;
        continue;
      }
      markers::Sighting s;
      s.id = obs.id;
      s.image = "keyframe " + std::to_string(id.value());
      const auto local = markers::marker_corners(size);
      for (int c = 0; c < 4; ++c) {
        s.corners[c] = world_from_cam * (pose->best.camera_from_marker * local[c]);
        s.alternative[c] = world_from_cam * (pose->alternative.camera_from_marker * local[c]);
      }
      s.ambiguous = pose->ambiguous;
      s.reprojection_error_px = pose->reprojection_error_px();
      s.distance = pose->distance();
      s.edge_length = size;
      sightings[obs.id].push_back(s);
    }
  }
  const markers::FusionOptions fusion{.min_gate = o.fusion_min_gate,
                                      .mad_factor = o.fusion_mad_factor};
  for (const auto& [id, group] : sightings) {
    const markers::MapMarker fused = markers::fuse_sightings(group, fusion);
    SlamMarker m;
    m.id = id;
    m.corners = fused.corners;
    m.edge_length = fused.edge_length;
    m.keyframes = seen_in[id];
    m.sightings = fused.sightings;
    m.rejected_sightings = fused.rejected_sightings;
    m.fusion_residual = fused.residual;
    if (o.triangulation_iterations > 0) triangulate_marker(k, views[id], o, m);
    out.markers.emplace(id, std::move(m));
  }
  return out;
}

std::string describe_sightings(const SlamMarkers& markers) {
  if (markers.markers.empty()) return "no marker seen in any keyframe";
  std::ostringstream s;
  bool first = true;
  for (const auto& [id, m] : markers.markers) {
    if (!first) s << "; ";
    first = false;
    s << "id " << id << " in keyframe" << (m.keyframes.size() == 1 ? " " : "s ");
    const std::size_t shown = std::min<std::size_t>(m.keyframes.size(), 6);
    for (std::size_t i = 0; i < shown; ++i)
      s << (i ? ", " : "") << m.keyframes[i].value();
    if (shown < m.keyframes.size()) s << ", ... (" << m.keyframes.size() << " keyframes)";
    const Eigen::Vector3d c = m.centre();
    s << " at (" << std::round(c.x() * 100) / 100 << ", " << std::round(c.y() * 100) / 100 << ", "
      << std::round(c.z() * 100) / 100 << ")";
  }
  return s.str();
}

}  // namespace coloc::registration::align
