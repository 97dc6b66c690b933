#include "registration/align/refine.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>

#include "registration/render/renderer.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::align {

namespace {

KeyframeRefinement refine_one(const MatchView& view, render::Renderer& renderer,
                              slam::features::OrbExtractor& extractor, const PinholeCamera& camera,
                              const RefineOptions& o) {
  Stopwatch watch;
  KeyframeRefinement r;
  r.id = view.id;
  r.timestamp = view.timestamp;
  r.registered = view.cam_from_world;
  // Render, match, PnP; then again from the PnP pose: the rendering then looks almost like the
  // image, so the features of both sit on the same texture spots (the first pass's pose carries
  // the view-dependent shifts of features seen from a few centimetres and a degree away).
  ScanMatch m;
  SE3 pose = r.registered;
  double first_offset = 0.0;
  for (int it = 0; it < o.iterations; ++it) {
    const render::RenderResult rendering = renderer.render(camera, pose, render::Layer::kPoints);
    ScanMatch next =
        match_to_rendering(*view.features, rendering, pose, camera, extractor, o.match);
    if (it == 0) {
      first_offset = next.median_offset_px;
    } else if (!next.ok()) {
      break;  // keep the first pass's result
    }
    m = std::move(next);
    if (!m.has_pose) break;
    pose = m.cam_from_world;
  }
  r.outcome = m.outcome;
  r.image_features = m.image_features;
  r.rendered_features = m.rendered_features;
  r.matches = m.matches.size();
  r.inliers = m.inliers;
  r.has_pose = m.has_pose;
  r.median_offset_px = first_offset;
  r.rms_reprojection_px = m.rms_reprojection_px;
  if (m.has_pose) {
    r.pnp = m.cam_from_world;
    r.correction_m = pose_distance_m(r.pnp, r.registered);
    r.correction_deg = pose_angle_deg(r.pnp, r.registered);
    r.implausible = r.correction_m > o.max_correction_m || r.correction_deg > o.max_correction_deg;
  }
  r.accepted = m.ok() && !r.implausible;
  r.correspondences = std::move(m.matches);
  r.ms = watch.elapsed_ms();
  return r;
}

}  // namespace

void RefineOptions::check() const {
  match.check();
  render.check();
  if (!(max_correction_m > 0.0))
    throw Error("must be positive (metres)", {.field = "max_correction_m"});
  if (!(max_correction_deg > 0.0))
    throw Error("must be positive (degrees)", {.field = "max_correction_deg"});
  if (threads < 1) throw Error("must be >= 1", {.field = "threads"});
  if (!(keyframe_spacing_m >= 0.0))
    throw Error("must be >= 0 (metres)", {.field = "keyframe_spacing_m"});
  if (!(keyframe_spacing_deg >= 0.0 && keyframe_spacing_deg <= 180.0))
    throw Error("must be in [0, 180] (degrees)", {.field = "keyframe_spacing_deg"});
  if (iterations < 1 || iterations > 5) throw Error("must be in [1, 5]", {.field = "iterations"});
}

std::string KeyframeRefinement::reason() const {
  if (outcome == MatchOutcome::kOk && implausible) return "implausible";
  return outcome_name(outcome);
}

PinholeCamera ideal_camera(const slam::map::Map& map, const Camera& camera) {
  if (map.keyframes().empty()) throw Error("the map has no keyframe", {.field = "keyframes"});
  const slam::frame::FrameGeometry& g = map.keyframes().begin()->second.frame.geometry();
  PinholeCamera c;
  c.fx = g.fx;
  c.fy = g.fy;
  c.cx = g.cx;
  c.cy = g.cy;
  c.width = image_width(camera);
  c.height = image_height(camera);
  if (c.width <= 0 || c.height <= 0)
    throw Error("the camera has no image size", {.field = "camera"});
  return c;
}

std::vector<KeyframeRefinement> match_views(const std::vector<MatchView>& views,
                                            const render::PointCloud& cloud,
                                            const PinholeCamera& camera, const RefineOptions& o,
                                            const RefineProgress& progress) {
  o.check();
  cloud.check();
  if (cloud.points.empty()) throw Error("the scan's point cloud is empty", {.field = "cloud"});
  for (const MatchView& v : views) {
    if (v.features == nullptr) throw Error("a view has no features", {.field = "views"});
  }
  std::vector<KeyframeRefinement> out(views.size());
  std::atomic<std::size_t> next{0};
  std::mutex progress_mutex;
  std::size_t done = 0;
  std::exception_ptr failure;
  std::mutex failure_mutex;
  // Prepared once and drawn by every thread: a copy per thread cost ~1.5 GB each at a site's
  // 38 M points.
  const auto shared = std::make_shared<const render::SharedPointCloud>(cloud, o.render);
  const auto work = [&] {
    try {
      render::Renderer renderer(o.render, shared);  // this thread's own GL context
      slam::features::OrbExtractor extractor(o.match.orb);
      for (std::size_t i = next++; i < views.size(); i = next++) {
        out[i] = refine_one(views[i], renderer, extractor, camera, o);
        if (progress) {
          const std::lock_guard lock(progress_mutex);
          progress(++done, views.size());
        }
      }
    } catch (...) {
      const std::lock_guard lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = views.size();  // the others stop at their next view
    }
  };
  const int n = std::min<int>(o.threads, static_cast<int>(std::max<std::size_t>(views.size(), 1)));
  std::vector<std::thread> workers;
  for (int t = 1; t < n; ++t)
    workers.emplace_back(work);
  work();
  for (std::thread& t : workers)
    t.join();
  if (failure) std::rethrow_exception(failure);
  return out;
}

std::vector<KeyframeRefinement> match_keyframes(const slam::map::Map& map,
                                                const render::PointCloud& cloud,
                                                const PinholeCamera& camera, const RefineOptions& o,
                                                const RefineProgress& progress,
                                                const std::vector<KeyframeId>& only) {
  std::vector<KeyframeId> ids = only;
  if (ids.empty()) {
    for (const auto& [id, kf] : map.keyframes())
      ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  std::vector<MatchView> views;
  views.reserve(ids.size());
  for (KeyframeId id : ids) {
    const slam::map::Keyframe* kf = map.keyframe(id);
    if (kf == nullptr)
      throw Error("no keyframe " + std::to_string(id.value()) + " in the map",
                  {.field = "keyframes"});
    views.push_back({id, kf->frame.timestamp, &kf->frame.features, kf->cam_from_world()});
  }
  return match_views(views, cloud, camera, o, progress);
}

std::vector<KeyframeId> spaced_keyframes(const slam::map::Map& map, const RefineOptions& o) {
  std::vector<KeyframeId> ids;
  for (const auto& [id, kf] : map.keyframes())
    ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  if (o.keyframe_spacing_m <= 0.0) return ids;
  // A plain scan of the chosen ones: a site's 1,462 keyframes keep ~500, under a million
  // distance checks, far below one keyframe's matching.
  const double min_cos = std::cos(o.keyframe_spacing_deg * M_PI / 180.0);
  struct Chosen {
    Eigen::Vector3d centre, axis;
  };
  std::vector<Chosen> kept;
  std::vector<KeyframeId> chosen;
  for (KeyframeId id : ids) {
    const slam::map::Keyframe& kf = *map.keyframe(id);
    const Eigen::Vector3d centre = kf.camera_centre();
    const Eigen::Vector3d axis = kf.cam_from_world().so3().inverse() * Eigen::Vector3d::UnitZ();
    const bool covered = std::any_of(kept.begin(), kept.end(), [&](const Chosen& c) {
      return (c.centre - centre).norm() < o.keyframe_spacing_m && c.axis.dot(axis) > min_cos;
    });
    if (covered) continue;
    kept.push_back({centre, axis});
    chosen.push_back(id);
  }
  return chosen;
}

RefineReport refine_with_point_cloud(slam::map::Map& map, const render::PointCloud& cloud,
                                     const ScanCorners& scan, const Camera& camera,
                                     const std::vector<int>& use_ids, const MarkerBaOptions& ba,
                                     const RefineOptions& o, const RefineProgress& progress) {
  o.check();
  ba.check();
  RefineReport report;
  Stopwatch watch;
  report.keyframes =
      match_keyframes(map, cloud, ideal_camera(map, camera), o, progress, spaced_keyframes(map, o));
  report.ms_match = watch.elapsed_ms();
  std::unordered_set<KeyframeId> fixed;
  std::vector<ScanPointObservation> terms;
  for (const KeyframeRefinement& k : report.keyframes) {
    if (!k.accepted) continue;
    ++report.accepted;
    if (o.hold_fixed || !o.bundle_adjust) {
      map.keyframe(k.id)->frame.cam_from_world = k.pnp;
      fixed.insert(k.id);
    } else {
      for (const ScanCorrespondence& c : k.correspondences) {
        if (c.inlier) terms.push_back({k.id, c.image_px, c.world});
      }
    }
  }
  if (report.accepted == 0 || !o.bundle_adjust) return report;
  watch.restart();
  report.ba = marker_bundle_adjustment(map, scan, camera, use_ids, ba, fixed, terms);
  report.ms_ba = watch.elapsed_ms();
  return report;
}

}  // namespace coloc::registration::align
