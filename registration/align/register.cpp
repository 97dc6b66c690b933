#include "registration/align/register.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "registration/align/transform.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::align {

namespace {

using Json = nlohmann::ordered_json;

double finite_or_zero(double v) {
  return std::isfinite(v) ? v : 0.0;
}

Json sim3_json(const Sim3& t) {
  const Eigen::Quaterniond& q = t.so3().quaternion();
  return Json{{"scale", t.scale()},
              {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}},
              {"translation", {t.translation().x(), t.translation().y(), t.translation().z()}}};
}

}  // namespace

const char* level_name(Level level) {
  return level == Level::kRough ? "rough" : "markers";
}

Level parse_level(const std::string& name) {
  if (name == "rough") return Level::kRough;
  if (name == "markers") return Level::kMarkers;
  throw Error("unknown registration level '" + name + "' (rough or markers)", {.field = "level"});
}

void RegisterOptions::check() const {
  corners.check();
  rough.check();
  ba.check();
  if (!(ba_max_rough_residual > 0.0))
    throw Error("must be positive (metres)", {.field = "ba_max_rough_residual"});
}

RegistrationResult register_map(slam::map::Map& map, const markers::MarkerMap& scan,
                                const Camera& camera, const RegisterOptions& o) {
  o.check();
  RegistrationResult r;
  r.level = o.level;
  Stopwatch watch;
  r.slam_markers = slam_marker_corners(map, camera, o.corners);
  r.ms_corners = watch.elapsed_ms();
  watch.restart();
  r.rough = rough_align(r.slam_markers, scan, o.rough);
  r.scan_from_slam = r.rough.scan_from_slam;
  transform_map(map, r.scan_from_slam);
  r.ms_rough = watch.elapsed_ms();
  if (o.level == Level::kRough) return r;

  watch.restart();
  ScanCorners corners;
  std::vector<int> use;
  for (const MarkerResidual& m : r.rough.markers) {
    if (m.residual < o.ba_max_rough_residual && m.consistent) use.push_back(m.id);
  }
  for (int id : use)
    corners.emplace(id, scan.markers.at(id).corners);
  r.ba = marker_bundle_adjustment(map, corners, camera, use, o.ba);
  r.ms_ba = watch.elapsed_ms();
  return r;
}

std::string registration_json(const RegistrationResult& r) {
  Json j;
  j["level"] = level_name(r.level);
  j["scan_from_slam"] = sim3_json(r.scan_from_slam);
  Json rough;
  rough["inliers"] = r.rough.inliers;
  rough["rms_m"] = r.rough.rms;
  rough["only_in_map"] = r.rough.only_in_slam;
  rough["only_in_scan"] = r.rough.only_in_scan;
  Json markers = Json::array();
  for (const MarkerResidual& m : r.rough.markers) {
    const auto it = r.slam_markers.markers.find(m.id);
    Json e{{"id", m.id},         {"keyframes", m.keyframes},         {"residual_m", m.residual},
           {"inlier", m.inlier}, {"loo_residual_m", m.loo_residual}, {"consistent", m.consistent}};
    if (it != r.slam_markers.markers.end()) {
      e["sightings"] = it->second.sightings;
      e["triangulated"] = it->second.triangulated;
      e["triangulation_rms_px"] = finite_or_zero(it->second.reprojection_rms_px);
    }
    markers.push_back(e);
  }
  rough["markers"] = markers;
  rough["ms"] = r.ms_corners + r.ms_rough;
  j["rough"] = rough;
  if (r.ba) {
    const MarkerBaReport& b = *r.ba;
    Json ba{{"keyframes", b.keyframes},
            {"points", b.points},
            {"observations", b.observations},
            {"marker_observations", b.marker_observations},
            {"outliers", b.outliers},
            {"point_rms_px", {b.initial_point_rms_px, b.final_point_rms_px}},
            {"marker_rms_px", {b.initial_marker_rms_px, b.final_marker_rms_px}},
            {"rejected", b.rejected_ids()},
            {"rounds", b.rounds},
            {"iterations", b.iterations},
            {"ms", b.ms}};
    Json per = Json::array();
    for (const MarkerBaMarker& m : b.markers) {
      per.push_back({{"id", m.id},
                     {"keyframes", m.keyframes},
                     {"rms_px", {finite_or_zero(m.initial_rms_px), finite_or_zero(m.final_rms_px)}},
                     {"rejected", m.rejected}});
    }
    ba["markers"] = per;
    j["markers"] = ba;
  }
  return j.dump();
}

}  // namespace coloc::registration::align
