#include "slam/localize/localizer.hpp"

#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <variant>

#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/tuning/system_options.hpp"
#include "slam/tuning/tuning.hpp"

namespace coloc::slam::localize {

namespace {

double steady_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

std::unique_ptr<LocalizationMap> load_localization_map(const std::filesystem::path& path,
                                                       const bow::Vocabulary& vocabulary,
                                                       const mapdb::LoadOptions& options) {
  if (!options.rebuild_bow)
    throw Error("load_localization_map: relocalization needs the BoW database",
                {.file = path.string(), .field = "LoadOptions.rebuild_bow"});
  // Only what tracking and relocalization read stays resident: the depth images stay in the
  // file, the keyframes' BoW vectors in the BoW database's index, and no keyframe keeps its
  // keypoints' depth or its grid (nothing searches in a keyframe's image).
  mapdb::LoadOptions o = options;
  o.keyframe_depth = false;
  o.keyframe_bow = false;
  o.keyframe_search = false;
  mapdb::LoadedMap loaded = mapdb::load_map(path, vocabulary, o);
#if defined(__GLIBC__)
  // What the load dropped (grids, keypoint depth, BoW vectors, SQLite's page cache, decoded
  // blobs) is free but resident, in holes between the keyframes' arrays and in the BoW threads'
  // arenas: glibc returns whole free pages only when asked.
  malloc_trim(0);
#endif
  if (loaded.map.keyframe_count() == 0)
    throw Error("the map holds no keyframe to localize in",
                {.file = path.string(), .field = "keyframes"});
  auto out = std::make_unique<LocalizationMap>();
  out->shared.map = std::move(loaded.map);
  out->shared.database = std::move(loaded.database);
  out->metadata = std::move(loaded.metadata);
  out->geometries = std::move(loaded.geometries);
  return out;
}

settings::Settings settings_saved_in(const LocalizationMap& map,
                                     const std::filesystem::path& map_path) {
  const ErrorContext where{.file = map_path.string(), .field = "metadata.settings"};
  if (map.metadata.settings.empty()) throw Error("the map holds no camera settings", where);
  try {
    settings::Settings s =
        settings::parse_settings(map.metadata.settings, map_path.string() + " (metadata.settings)");
    return s;
  } catch (const Error& e) {
    // The key (and line) the settings reader named stay in the message: "must be positive"
    // alone does not say which setting.
    const ErrorContext& inner = e.context();
    std::string named = e.message();
    if (!inner.field.empty()) named = "'" + inner.field + "': " + named;
    if (inner.line) named = "line " + std::to_string(*inner.line) + ", " + named;
    throw Error("the settings saved in the map: " + named,
                {.file = where.file,
                 .field = inner.field.empty() ? where.field : where.field + "." + inner.field});
  }
}

const char* to_string(LocalizationState state) {
  switch (state) {
    case LocalizationState::kLost:
      return "lost";
    case LocalizationState::kTracking:
      return "tracking";
    case LocalizationState::kRelocalized:
      return "relocalized";
    case LocalizationState::kOdometry:
      return "odometry";
  }
  return "?";
}

void LocalizerOptions::check() const {
  tracking.check();
  extractor.check();
  odometry.check();
}

LocalizerOptions options_from_settings(const settings::Settings& settings) {
  // The Coloc.* keys are one table for the whole system (tuning.hpp): a map and its localizer
  // read the same settings file; the mapping and loop keys are checked and then unused here.
  system::SystemOptions system;
  system.tracking.rgb_input = settings.rgb_order;
  system::apply_tuning(settings, system);
  LocalizerOptions options;
  options.tracking = system.tracking;
  options.extractor = {settings.orb.n_features, settings.orb.scale_factor, settings.orb.n_levels,
                       settings.orb.ini_th_fast, settings.orb.min_th_fast};
  return options;
}

Localizer::Localizer(LocalizationMap& map, const bow::Vocabulary& vocabulary,
                     const settings::Settings& settings, LocalizerOptions options)
    : map_(map),
      vocabulary_(vocabulary),
      settings_(settings),
      options_(options),
      bridge_(options.odometry) {
  // Memory stays flat over hours: the tracker keeps its last frame record only.
  options_.tracking.keep_records = false;
  options_.tracking.wait_for_sink = false;
  options_.check();
  if (!settings_.depth)
    throw Error("Localizer: settings without depth (Camera.bf / ThDepth) for RGB-D",
                {.file = settings_.source.string(), .field = "Camera.bf"});
  if (vocabulary_.empty()) throw Error("Localizer: empty vocabulary");
  {
    std::lock_guard lock(map_.shared.mutex);
    if (map_.shared.map.keyframe_count() == 0)
      throw Error("Localizer: the map holds no keyframe", {.field = "keyframes"});
  }
  const int width = image_width(settings_.camera), height = image_height(settings_.camera);
  if (width > 0 && height > 0) start_tracking(width, height);
}

Localizer::~Localizer() = default;

void Localizer::start_tracking(int width, int height) {
  std::visit(
      [&](auto& camera) {
        camera.width = width;
        camera.height = height;
      },
      settings_.camera);
  const features::OrbExtractor probe(options_.extractor);
  auto geometry = std::make_shared<frame::FrameGeometry>(frame::FrameGeometry::make(
      settings_.camera, settings_.depth->bf, settings_.depth->close_depth, probe.scale_factors()));
  // Settings without a readout: the one estimated while the map was made, if it was.
  geometry->readout =
      settings_.readout_time.value_or(map_.metadata.estimated_readout.value_or(0.0));
  geometry->check();
  geometry_ = geometry;
  if (scan_anchor_) depth_sampler_.emplace(settings_.camera, scan_anchor_->options().stride_px);
  // No keyframe sink: the tracker localizes only and its first frame relocalizes.
  tracker_ =
      std::make_unique<tracking::Tracker>(map_.shared, nullptr, vocabulary_, geometry_,
                                          options_.extractor, settings_.camera, options_.tracking);
  was_localized_ = false;
}

void Localizer::anchor_to_scan(std::shared_ptr<const ScanAnchor> anchor) {
  scan_anchor_ = std::move(anchor);
  depth_sampler_.reset();
  last_anchored_.reset();
  if (scan_anchor_ && geometry_)
    depth_sampler_.emplace(settings_.camera, scan_anchor_->options().stride_px);
}

void Localizer::anchor(const cv::Mat& depth, LocalizationResult& r) {
  if (!scan_anchor_ || !depth_sampler_ || depth.empty() || r.state == LocalizationState::kLost) {
    last_anchored_.reset();
    return;
  }
  const Stopwatch watch;
  const ScanAnchorOptions& o = scan_anchor_->options();
  const std::vector<Eigen::Vector3d> samples =
      depth_sampler_->points(depth, o.min_depth_m, o.max_depth_m);
  const SE3 visual = r.world_from_cam;
  std::optional<AnchorResult> a;
  if (last_anchored_) {
    // The last anchored pose moved by the visual motion since: the anchor follows the scan. A
    // refused step starts over cold from the visual pose, then (where odometry bridges the
    // visual pose and it may have drifted) cold from the same start.
    const SE3 start = last_anchored_->first * last_anchored_->second.inverse() * visual;
    a = scan_anchor_->align(samples, start, visual, false);
    if (!a) a = scan_anchor_->align(samples, visual, visual, true);
    if (!a) a = scan_anchor_->align(samples, start, visual, true);
  } else {
    a = scan_anchor_->align(samples, visual, visual, true);
  }
  if (a) {
    r.world_from_cam = a->world_from_cam;
    r.scan_anchored = true;
    r.scan_inliers = a->inliers;
    r.scan_rms_m = a->rms_m;
    last_anchored_.emplace(a->world_from_cam, visual);
    ++stats_.anchored;
  } else {
    last_anchored_.reset();
  }
  r.anchor_ms = watch.elapsed_ms();
  if (a)
    spdlog::debug(
        "scan anchor: {} of {} depth samples on the surface, {} iterations, {:.1f} mm RMS, "
        "conditioning {:.4f}",
        a->inliers, a->samples, a->iterations, 1e3 * a->rms_m, a->conditioning);
  stats_.anchor_ms.add(r.anchor_ms);
}

void Localizer::reset() {
  last_anchored_.reset();
  bridge_.reset();
  if (geometry_) start_tracking(image_width(settings_.camera), image_height(settings_.camera));
}

LocalizationResult Localizer::localize(const cv::Mat& image, const cv::Mat& depth,
                                       double timestamp) {
  if (image.empty()) throw Error("Localizer::localize: empty image");
  const Stopwatch watch;
  if (first_frame_start_s_ < 0.0) first_frame_start_s_ = steady_seconds();
  if (!tracker_) start_tracking(image.cols, image.rows);
  if (image.cols != image_width(settings_.camera) || image.rows != image_height(settings_.camera))
    throw Error("Localizer::localize: image is " + std::to_string(image.cols) + "x" +
                    std::to_string(image.rows) + " but the settings say " +
                    std::to_string(image_width(settings_.camera)) + "x" +
                    std::to_string(image_height(settings_.camera)),
                {.file = settings_.source.string(), .field = "Camera.width"});
  if (!depth.empty() && depth.size() != image.size())
    throw Error("Localizer::localize: depth image size differs from the colour image");

  const tracking::TrackingResult t = tracker_->track(image, depth, timestamp);
  LocalizationResult r;
  r.timestamp = timestamp;
  r.extract_ms = t.extract_ms;
  r.track_ms = t.track_ms;
  r.pose_ms = t.pose_ms;
  r.local_map_ms = t.local_map_ms;
  if (t.state == tracking::TrackingState::kOk) {
    r.state = was_localized_ ? LocalizationState::kTracking : LocalizationState::kRelocalized;
    r.world_from_cam = t.cam_from_world.inverse();
    r.inliers = t.inliers;
    r.reprojection_rms_px = reprojection_rms();
    if (!tracker_->records().empty()) r.reference = tracker_->records().back().reference;
    bridge_.anchor(tracker_->current_frame(), t.cam_from_world);
  } else if (const auto bridged = bridge_.track(tracker_->current_frame())) {
    r.state = LocalizationState::kOdometry;
    r.world_from_cam = bridged->cam_from_world.inverse();
    r.inliers = bridged->inliers;
  }
  anchor(depth, r);
  const bool localized =
      r.state == LocalizationState::kTracking || r.state == LocalizationState::kRelocalized;
  ++stats_.frames;
  if (r.state == LocalizationState::kOdometry) {
    ++stats_.bridged;
  } else if (localized) {
    ++stats_.localized;
    if (!was_localized_) ++stats_.relocalizations;
    if (stats_.first_localized_frame < 0) {
      stats_.first_localized_frame = static_cast<std::int64_t>(stats_.frames - 1);
      stats_.ms_to_first_pose = 1e3 * (steady_seconds() - first_frame_start_s_);
    }
  } else {
    ++stats_.lost;
  }
  was_localized_ = localized;
  r.total_ms = watch.elapsed_ms();
  stats_.total_ms.add(r.total_ms);
  return r;
}

double Localizer::reprojection_rms() const {
  const frame::Frame& f = tracker_->last_frame();
  if (!f.has_pose) return 0.0;
  const frame::FrameGeometry& g = f.geometry();
  double sum = 0.0;
  std::size_t n = 0;
  std::lock_guard lock(map_.shared.mutex);
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (!f.points[i].valid() || f.outlier[i]) continue;
    const map::MapPoint* p = map_.shared.map.point(f.points[i]);
    if (!p) continue;
    const Eigen::Vector3d pc = f.cam_from_world * p->position;
    if (pc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = g.project(pc);
    const auto& kp = f.features.keypoints[i];
    sum += (uv - Eigen::Vector2d(kp.ux, kp.uy)).squaredNorm();
    ++n;
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

}  // namespace coloc::slam::localize
