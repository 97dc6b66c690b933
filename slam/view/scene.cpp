#include "slam/view/scene.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "slam/core/error.hpp"

namespace coloc::slam::view {
namespace {

using Json = nlohmann::json;

// Rounded so the page's JSON stays small: 0.1 mm is far below what a map resolves.
double round_to(double v, double step) {
  return std::isfinite(v) ? std::round(v / step) * step : 0.0;
}

Json pose_json(const SE3& world_from_cam) {
  const Eigen::Quaterniond& q = world_from_cam.quaternion();
  const Eigen::Vector3d& t = world_from_cam.translation();
  return Json::array({round_to(q.x(), 1e-6), round_to(q.y(), 1e-6), round_to(q.z(), 1e-6),
                      round_to(q.w(), 1e-6), round_to(t.x(), 1e-4), round_to(t.y(), 1e-4),
                      round_to(t.z(), 1e-4)});
}

// RMS reprojection error (undistorted pixels) of the keyframe's map points; -1 without any.
double keyframe_residual(const map::Map& map, const map::Keyframe& kf, std::size_t& tracked) {
  const frame::Frame& f = kf.frame;
  double sum = 0.0;
  tracked = 0;
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const map::MapPoint* p = f.points[i].valid() ? map.point(f.points[i]) : nullptr;
    if (p == nullptr) continue;
    const Eigen::Vector3d c = f.cam_from_world * p->position;
    if (c.z() <= 0.0) continue;
    sum += (f.geometry().project(c) - f.pixel(i)).squaredNorm();
    ++tracked;
  }
  return tracked > 0 ? std::sqrt(sum / static_cast<double>(tracked)) : -1.0;
}

SceneKeyframe scene_keyframe(const map::Map& map, const map::Keyframe& kf, bool residual) {
  SceneKeyframe k;
  k.id = kf.id.value();
  k.timestamp = kf.frame.timestamp;
  k.world_from_cam = kf.cam_from_world().inverse();
  if (kf.parent.valid()) k.parent = kf.parent.value();
  k.keypoints = kf.frame.size();
  k.markers = kf.markers.size();
  if (residual) {
    k.residual_px = keyframe_residual(map, kf, k.tracked);
  } else {
    k.tracked = kf.frame.tracked_count();
  }
  return k;
}

Json markers_json(const std::vector<SceneMarker>& markers) {
  Json out = Json::array();
  for (const SceneMarker& m : markers) {
    Json corners = Json::array();
    for (const auto& c : m.corners)
      for (int a = 0; a < 3; ++a)
        corners.push_back(round_to(c[a], 1e-4));
    out.push_back({{"id", m.id}, {"corners", corners}});
  }
  return out;
}

Json keyframes_json(const std::vector<SceneKeyframe>& keyframes) {
  Json out = Json::array();
  for (const SceneKeyframe& k : keyframes) {
    out.push_back({{"id", k.id},
                   {"t", k.timestamp},
                   {"pose", pose_json(k.world_from_cam)},
                   {"parent", k.parent ? Json(*k.parent) : Json()},
                   {"keypoints", k.keypoints},
                   {"tracked", k.tracked},
                   {"markers", k.markers},
                   {"residual_px", round_to(k.residual_px, 1e-3)},
                   {"marker_residual_px", round_to(k.marker_residual_px, 1e-3)}});
  }
  return out;
}

// Edges as [[a, b(, weight)], ...], built element by element (GCC 12 sees a null dereference
// in nlohmann's conversion of nested std::array containers).
template <std::size_t N>
Json edges_json(const std::vector<std::array<std::uint64_t, N>>& edges) {
  Json out = Json::array();
  for (const auto& e : edges) {
    Json row = Json::array();
    for (std::uint64_t v : e)
      row.push_back(v);
    out.push_back(std::move(row));
  }
  return out;
}

}  // namespace

void SceneOptions::check() const {
  if (min_covisibility < 1) throw Error("must be at least 1", {.field = "min_covisibility"});
}

MapScene scene_of(const map::Map& map, const SceneOptions& options) {
  options.check();
  MapScene s;
  std::map<std::uint64_t, const map::Keyframe*> by_id;
  for (const auto& [id, kf] : map.keyframes())
    by_id.emplace(id.value(), &kf);
  s.keyframes.reserve(by_id.size());
  for (const auto& [id, kf] : by_id) {
    s.keyframes.push_back(scene_keyframe(map, *kf, options.residuals));
    for (const auto& [other, weight] : kf->covisibility) {
      if (other.value() > id && weight >= options.min_covisibility)
        s.covisibility.push_back({id, other.value(), static_cast<std::uint64_t>(weight)});
    }
    for (const KeyframeId other : kf->loop_edges) {
      if (other.value() > id) s.loop_edges.push_back({id, other.value()});
    }
  }
  if (!by_id.empty()) {
    const frame::Frame& f = by_id.begin()->second->frame;
    PinholeCamera c;
    c.width = f.features.image_width;
    c.height = f.features.image_height;
    c.fx = f.geometry().fx;
    c.fy = f.geometry().fy;
    c.cx = f.geometry().cx;
    c.cy = f.geometry().cy;
    s.camera = c;
  }
  s.points.positions.reserve(map.point_count());
  s.points.observations.reserve(map.point_count());
  for (const auto& [id, p] : map.points()) {
    s.points.positions.push_back(p.position.cast<float>());
    s.points.observations.push_back(static_cast<std::uint32_t>(p.observations.size()));
  }
  return s;
}

void add_marker_residuals(MapScene& scene, const map::Map& map, const Camera& camera) {
  std::map<int, const SceneMarker*> scan;
  for (const SceneMarker& m : scene.scan_markers)
    scan.emplace(m.id, &m);
  for (SceneKeyframe& k : scene.keyframes) {
    const map::Keyframe* kf = map.keyframe(KeyframeId(k.id));
    if (kf == nullptr) continue;
    double sum = 0.0;
    int n = 0;
    for (const auto& obs : kf->markers) {
      const auto it = scan.find(obs.id);
      if (it == scan.end()) continue;
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d p = kf->cam_from_world() * it->second->corners[c];
        if (p.z() <= 0.0) continue;
        sum += (project(camera, p) - obs.corners[c]).squaredNorm();
        ++n;
      }
    }
    if (n > 0) k.marker_residual_px = std::sqrt(sum / n);
  }
}

std::string scene_json(const MapScene& scene, std::uint64_t version) {
  Json xyz = Json::array();
  for (const Eigen::Vector3f& p : scene.points.positions)
    for (int a = 0; a < 3; ++a)
      xyz.push_back(round_to(p[a], 1e-4));
  Json camera;
  if (scene.camera) {
    const PinholeCamera& c = *scene.camera;
    camera = {{"width", c.width}, {"height", c.height}, {"fx", c.fx},
              {"fy", c.fy},       {"cx", c.cx},         {"cy", c.cy}};
  }
  const Json j{{"version", version},
               {"frame", scene.frame},
               {"camera", camera},
               {"keyframes", keyframes_json(scene.keyframes)},
               {"covisibility", edges_json(scene.covisibility)},
               {"loop_edges", edges_json(scene.loop_edges)},
               {"points", {{"xyz", xyz}, {"observations", scene.points.observations}}},
               {"slam_markers", markers_json(scene.slam_markers)},
               {"scan_markers", markers_json(scene.scan_markers)}};
  return j.dump();
}

std::optional<std::string> keyframe_json(const map::Map& map, std::uint64_t id) {
  const map::Keyframe* kf = map.keyframe(KeyframeId(id));
  if (kf == nullptr) return std::nullopt;
  const SceneKeyframe k = scene_keyframe(map, *kf, true);
  const frame::Frame& f = kf->frame;
  Json kp = Json::array();
  std::string tracked(f.size(), '0');
  for (std::size_t i = 0; i < f.size(); ++i) {
    kp.push_back(round_to(f.features.keypoints[i].x, 0.1));
    kp.push_back(round_to(f.features.keypoints[i].y, 0.1));
    if (i < f.points.size() && f.points[i].valid() && map.point(f.points[i]) != nullptr)
      tracked[i] = '1';
  }
  Json markers = Json::array();
  for (const auto& m : kf->markers) {
    Json corners = Json::array();
    for (const auto& c : m.corners) {
      corners.push_back(round_to(c.x(), 0.01));
      corners.push_back(round_to(c.y(), 0.01));
    }
    markers.push_back({{"id", m.id}, {"corners", corners}});
  }
  const Json j{{"id", k.id},
               {"t", k.timestamp},
               {"width", f.features.image_width},
               {"height", f.features.image_height},
               {"pose", pose_json(k.world_from_cam)},
               {"residual_px", round_to(k.residual_px, 1e-3)},
               {"keypoints", kp},
               {"tracked", tracked},
               {"markers", markers}};
  return j.dump();
}

}  // namespace coloc::slam::view
