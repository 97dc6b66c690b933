#include "registration/align/register.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

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

// `use` without the markers the BA rejected: the refinement's BA does not bring them back.
std::vector<int> kept_ids(const std::vector<int>& use, const std::vector<int>& rejected) {
  std::vector<int> out;
  for (int id : use) {
    if (std::find(rejected.begin(), rejected.end(), id) == rejected.end()) out.push_back(id);
  }
  return out;
}

Json refine_json(const RefineReport& f) {
  Json per = Json::array();
  std::map<std::string, std::size_t> reasons;  // ok, implausible or the outcome that failed
  std::vector<double> offsets, corrections_m, corrections_deg;
  for (const KeyframeRefinement& k : f.keyframes) {
    ++reasons[k.reason()];
    if (k.accepted) {
      offsets.push_back(k.median_offset_px);
      corrections_m.push_back(k.correction_m);
      corrections_deg.push_back(k.correction_deg);
    }
    per.push_back({{"id", k.id.value()},
                   {"timestamp", k.timestamp},
                   {"reason", k.reason()},
                   {"accepted", k.accepted},
                   {"matches", k.matches},
                   {"inliers", k.inliers},
                   {"correction_m", k.correction_m},
                   {"correction_deg", k.correction_deg},
                   {"median_offset_px", k.median_offset_px},
                   {"rms_reprojection_px", k.rms_reprojection_px}});
  }
  const auto med = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  Json outcome_counts = Json::object();
  for (const auto& [reason, count] : reasons)
    outcome_counts[reason] = count;
  Json j{{"keyframes", f.keyframes.size()},
         {"accepted", f.accepted},
         {"outcomes", outcome_counts},
         {"median_offset_px", med(offsets)},
         {"median_correction_m", med(corrections_m)},
         {"median_correction_deg", med(corrections_deg)},
         {"ms_match", f.ms_match},
         {"ms_ba", f.ms_ba}};
  if (f.ba) {
    j["ba"] = {{"marker_rms_px", {f.ba->initial_marker_rms_px, f.ba->final_marker_rms_px}},
               {"point_rms_px", {f.ba->initial_point_rms_px, f.ba->final_point_rms_px}},
               {"outliers", f.ba->outliers},
               {"iterations", f.ba->iterations}};
  }
  j["per_keyframe"] = per;
  return j;
}

}  // namespace

const char* level_name(Level level) {
  switch (level) {
    case Level::kRough:
      return "rough";
    case Level::kMarkers:
      return "markers";
    case Level::kPointcloud:
      return "pointcloud";
    case Level::kSurface:
      return "surface";
  }
  return "unknown";
}

Level parse_level(const std::string& name) {
  if (name == "rough") return Level::kRough;
  if (name == "markers") return Level::kMarkers;
  if (name == "pointcloud") return Level::kPointcloud;
  if (name == "surface") return Level::kSurface;
  throw Error("unknown registration level '" + name + "' (rough, markers, pointcloud or surface)",
              {.field = "level"});
}

void RegisterOptions::check() const {
  corners.check();
  rough.check();
  ba.check();
  refine.check();
  scan_surface.check();
  surface.check();
  if (!(ba_max_rough_residual > 0.0))
    throw Error("must be positive (metres)", {.field = "ba_max_rough_residual"});
}

RegistrationResult register_map(slam::map::Map& map, const markers::MarkerMap& scan,
                                const Camera& camera, const RegisterOptions& o,
                                const render::PointCloud* cloud, const RefineProgress& progress,
                                const KeyframeDepthSamples* depth) {
  o.check();
  if ((o.level == Level::kPointcloud || o.level == Level::kSurface) &&
      (cloud == nullptr || cloud->points.empty()))
    throw Error(std::string("level ") + level_name(o.level) + " needs the scan's points",
                {.field = "cloud"});
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
  if (!r.ba->usable()) return r;
  if (o.level == Level::kSurface) {
    watch.restart();
    const ScanSurface surface(*cloud, o.scan_surface);
    SurfaceBaMarkers kept;
    kept.corners = &corners;
    kept.use_ids = kept_ids(use, r.ba->rejected_ids());
    kept.options = o.ba;
    r.surface = surface_bundle_adjustment(map, surface, camera,
                                          depth ? *depth : KeyframeDepthSamples{}, o.surface, kept);
    r.ms_surface = watch.elapsed_ms();
    return r;
  }
  if (o.level != Level::kPointcloud) return r;

  watch.restart();
  r.refine = refine_with_point_cloud(
      map, *cloud, corners, camera,
      r.ba->rejected_ids().empty() ? use : kept_ids(use, r.ba->rejected_ids()), o.ba, o.refine,
      progress);
  r.ms_refine = watch.elapsed_ms();
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
  if (r.refine) j["pointcloud"] = refine_json(*r.refine);
  if (r.surface) {
    j["surface"] = Json::parse(surface_ba_json(*r.surface));
    j["surface"]["ms"] = r.ms_surface;
  }
  return j.dump();
}

}  // namespace coloc::registration::align
