#include "slam/system/system.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <variant>

#include "markers/detector.hpp"
#include "slam/core/error.hpp"
#include "slam/tuning/tuning.hpp"

namespace coloc::slam::system {

namespace {

// Median window and iterations of the local BAs, and the shares of their time.
std::string describe_local_ba(const std::vector<mapping::LocalBaRun>& runs) {
  const auto median = [&](auto field) {
    std::vector<double> v;
    for (const mapping::LocalBaRun& r : runs)
      v.push_back(static_cast<double>(field(r)));
    return summarize(v).median;
  };
  optim::BundleTiming sum;
  for (const mapping::LocalBaRun& r : runs) {
    sum.build_ms += r.timing.build_ms;
    sum.preprocess_ms += r.timing.preprocess_ms;
    sum.evaluate_ms += r.timing.evaluate_ms;
    sum.linear_solver_ms += r.timing.linear_solver_ms;
    sum.total_ms += r.timing.total_ms;
  }
  const auto share = [&](double ms) {
    return sum.total_ms > 0.0 ? 100.0 * ms / sum.total_ms : 0.0;
  };
  return fmt::format(
      "local BA window median: {} free + {} fixed keyframes, {} points, {} observations, {} "
      "iterations; time: problem {:.0f} %, preprocessing {:.0f} %, residuals and Jacobians "
      "{:.0f} %, linear solver {:.0f} %",
      median([](const auto& r) { return r.free_poses; }),
      median([](const auto& r) { return r.fixed_poses; }),
      median([](const auto& r) { return r.points; }),
      median([](const auto& r) { return r.observations; }),
      median([](const auto& r) { return r.iterations; }), share(sum.build_ms),
      share(sum.preprocess_ms), share(sum.evaluate_ms), share(sum.linear_solver_ms));
}

}  // namespace

std::string SystemSummary::describe() const {
  std::ostringstream s;
  s << "frames " << frames << ", tracked " << tracked << ", lost " << lost << ", keyframes "
    << keyframes << ", map points " << points << ", relocalizations " << relocalizations
    << (estimated_readout
            ? fmt::format(", rolling-shutter readout estimated {:.1f} ms", 1e3 * *estimated_readout)
            : std::string())
    << ", markers " << mapping.markers << "\n"
    << "keyframes made " << keyframe_decisions.made << " (kept " << keyframes << "), deferred "
    << keyframe_decisions.deferred << " frames, refused for a busy mapper "
    << keyframe_decisions.refused_busy << "\n"
    << "tracking ms/frame: median " << total_ms.median << ", p99 " << total_ms.p99
    << " (extraction median " << extract_ms.median
    << (extracted_ahead > 0
            ? fmt::format(", {} frames extracted ahead on a thread of their own", extracted_ahead)
            : std::string())
    << ")\n";
  const SampleStats ba = summarize(mapping.ba_ms);
  s << "local BA: " << mapping.ba_runs << " runs (" << mapping.ba_aborted << " aborted), ms median "
    << ba.median << ", p99 " << ba.p99 << "; keyframes culled " << mapping.keyframes_culled
    << ", points culled " << mapping.points_culled << ", fused " << mapping.points_fused
    << ", triangulated " << mapping.points_triangulated << "; mapper ms per keyframe median "
    << summarize(mapping.keyframe_ms).median << ", p99 " << summarize(mapping.keyframe_ms).p99;
  if (!mapping.ba.empty()) s << "\n" << describe_local_ba(mapping.ba);
  std::vector<double> correction_ms;
  for (const auto& l : loop.loops)
    correction_ms.push_back(l.ms);
  const SampleStats corr = summarize(correction_ms);
  s << "\nloops: " << loop.loops.size() << " closed, " << loop.rejected << " of " << loop.candidates
    << " candidates rejected (" << loop.rejected_aliasing << " implausible, "
    << loop.rejected_look_alike << " by their depth), correction ms median " << corr.median
    << ", max " << corr.max << "; global BA " << loop.global_ba_runs << " runs ("
    << loop.global_ba_aborted << " aborted)";
  return s.str();
}

System::System(const settings::Settings& settings, const bow::Vocabulary& vocabulary,
               SystemOptions options)
    : options_(options),
      settings_(settings),
      vocabulary_(vocabulary),
      extractor_{settings.orb.n_features, settings.orb.scale_factor, settings.orb.n_levels,
                 settings.orb.ini_th_fast, settings.orb.min_th_fast},
      shared_(std::make_unique<map::SharedMap>()) {
  options_.tracking.rgb_input = settings.rgb_order;
  apply_tuning(settings, options_);
  if (!settings.depth)
    throw Error("System: settings without depth (Camera.bf / ThDepth) for RGB-D",
                {settings.source.string(), "Camera.bf"});
  if (vocabulary.empty()) throw Error("System: empty vocabulary");
  extractor_.check();
  if (options_.detect_markers) {
    markers::DetectorOptions d;
    d.dictionary = settings.markers.dictionary;
    detector_ = std::make_unique<markers::MarkerDetector>(d);
  }
  spdlog::debug("slam options (coloc -v shows them):\n{}", options_.describe());
  // No readout in the settings: unknown, so estimated (a global-shutter camera says 0).
  shared_->estimate_readout = !settings.readout_time && options_.mapping.estimate_readout;
  if (shared_->estimate_readout)
    shared_->readout =
        std::min(options_.mapping.readout_start / settings.fps, options_.mapping.readout_max);
  if (options_.loop.enabled)
    loop_closer_ = std::make_unique<loop::LoopCloser>(*shared_, options_.loop, settings.camera);
  mapper_ = std::make_unique<mapping::LocalMapper>(*shared_, vocabulary, detector_.get(),
                                                   settings.markers.size, options_.mapping,
                                                   loop_closer_.get());
  const int width = image_width(settings.camera), height = image_height(settings.camera);
  if (width > 0 && height > 0) {
    start_tracking(width, height);
  } else {
    spdlog::info("{}: no Camera.width/height; the image size comes from the first frame",
                 settings.source.string());
  }
  mapper_->start();
  if (loop_closer_) loop_closer_->start(mapper_.get());
}

void System::start_tracking(int width, int height) {
  std::visit(
      [&](auto& camera) {
        camera.width = width;
        camera.height = height;
      },
      settings_.camera);
  const features::OrbExtractor probe(extractor_);
  auto geometry = std::make_shared<frame::FrameGeometry>(frame::FrameGeometry::make(
      settings_.camera, settings_.depth->bf, settings_.depth->close_depth, probe.scale_factors()));
  geometry->readout = settings_.readout_time.value_or(0.0);
  geometry->check();
  tracker_ = std::make_unique<tracking::Tracker>(*shared_, mapper_.get(), vocabulary_, geometry,
                                                 extractor_, settings_.camera, options_.tracking);
}

System::~System() {
  shutdown();
}

void System::shutdown() {
  if (mapper_) mapper_->stop();
  if (loop_closer_) loop_closer_->stop();
  running_ = false;
}

mapdb::MapMetadata System::metadata() const {
  mapdb::MapMetadata m;
  // The checksum serializes the vocabulary (tens of ms): once per save is fine.
  m.vocabulary_checksum = mapdb::vocabulary_checksum(vocabulary_);
  m.vocabulary_words = vocabulary_.word_count();
  if (!settings_.source.empty()) {
    std::ifstream file(settings_.source);
    std::ostringstream text;
    text << file.rdbuf();
    m.settings = text.str();
  }
  m.camera = settings_.camera;
  m.frame_name = frame_name_;
  m.frame_from_slam = frame_from_slam_;
  if (shared_->estimate_readout) m.estimated_readout = shared_->readout.load();
  return m;
}

mapdb::SaveReport System::save_map(const std::filesystem::path& path,
                                   const mapdb::SaveOptions& options) const {
  const mapdb::MapMetadata m = metadata();
  if (running_) return mapdb::save_live_map(shared_->map, shared_->mutex, m, path, options);
  std::lock_guard lock(shared_->mutex);
  return mapdb::save_map(shared_->map, m, path, options);
}

mapping::GlobalBaReport System::optimize_map(const mapping::GlobalBaOptions& options,
                                             const mapping::InertialMeasurements& imu) {
  shutdown();
  mapping::InertialMeasurements this_recording = imu;
  this_recording.first_keyframe = std::max(imu.first_keyframe, first_keyframe_);
  mapping::GlobalBaReport report =
      mapping::global_bundle_adjustment(*shared_, options, this_recording);
  spdlog::debug(
      "global BA: {} keyframes, {} points, {} observations ({} outliers removed), rms {:.3f} -> "
      "{:.3f} px, {} iterations, {:.0f} ms",
      report.keyframes, report.points, report.observations, report.outliers, report.initial_rms_px,
      report.final_rms_px, report.iterations, report.ms);
  if (report.gravity_keyframes > 0)
    spdlog::info(
        "global BA: gravity from {} keyframes ({} dropped), residual rms {:.3f} m/s^2, "
        "accelerometer bias ({:.3f}, {:.3f}, {:.3f}) m/s^2 (camera frame)",
        report.gravity_keyframes, report.gravity_outliers, report.gravity_rms,
        report.accel_bias.x(), report.accel_bias.y(), report.accel_bias.z());
  if (report.gyro_pairs > 0)
    spdlog::info(
        "global BA: gyro between {} keyframe pairs ({} dropped), residual rms {:.3f} mrad, mean "
        "gyro bias ({:.4f}, {:.4f}, {:.4f}) rad/s (camera frame)",
        report.gyro_pairs, report.gyro_outliers, 1e3 * report.gyro_rms, report.gyro_bias.x(),
        report.gyro_bias.y(), report.gyro_bias.z());
  return report;
}

namespace {

// The same model and intrinsics (the image size may be unknown on one side).
bool same_intrinsics(Camera a, const Camera& b) {
  std::visit(
      [&](auto& camera) {
        camera.width = image_width(b);
        camera.height = image_height(b);
      },
      a);
  return a == b;
}

}  // namespace

System::System(const settings::Settings& settings, const bow::Vocabulary& vocabulary,
               SystemOptions options, mapdb::LoadedMap loaded)
    : System(settings, vocabulary, options) {
  {
    // Nothing has run yet: no frame tracked, the mapping threads wait on empty queues.
    std::lock_guard lock(shared_->mutex);
    shared_->map = std::move(loaded.map);
    shared_->database = std::move(loaded.database);
    first_keyframe_ = shared_->map.upcoming_keyframe_id();
  }
  frame_name_ = loaded.metadata.frame_name;
  frame_from_slam_ = loaded.metadata.frame_from_slam;
  // Loaded keyframes carry no rate (their compensation stays); new ones start from the estimate.
  if (shared_->estimate_readout && loaded.metadata.estimated_readout)
    shared_->readout = *loaded.metadata.estimated_readout;
  if (loaded.metadata.camera && !same_intrinsics(*loaded.metadata.camera, settings.camera))
    spdlog::warn("{}: the map was made with another camera model; its keyframes keep theirs",
                 settings.source.string());
  // A tracker built for a known image size saw the empty map: build it again for this one.
  if (tracker_) start_tracking(image_width(settings_.camera), image_height(settings_.camera));
  spdlog::info("continuing a map of {} keyframes and {} points (frame '{}')",
               shared_->map.keyframe_count(), shared_->map.point_count(), frame_name_);
}

tracking::TrackingResult System::track(const cv::Mat& image, const cv::Mat& depth,
                                       double timestamp) {
  check_image(image, depth);
  auto r = tracker_->track(image, depth, timestamp);
  account(image, r, timestamp);
  return r;
}

tracking::TrackingResult System::track(const cv::Mat& image, const cv::Mat& depth, double timestamp,
                                       tracking::ImageFeatures extracted) {
  check_image(image, depth);
  auto r = tracker_->track(image, depth, timestamp, std::move(extracted));
  ++extracted_ahead_;
  account(image, r, timestamp);
  return r;
}

tracking::FeatureExtraction System::feature_extraction() const {
  return {extractor_, settings_.camera, options_.tracking.rgb_input};
}

void System::check_image(const cv::Mat& image, const cv::Mat& depth) {
  if (image.empty()) throw Error("System::track: empty image");
  if (!tracker_) start_tracking(image.cols, image.rows);
  if (image.cols != image_width(settings_.camera) || image.rows != image_height(settings_.camera))
    throw Error("System::track: image is " + std::to_string(image.cols) + "x" +
                    std::to_string(image.rows) + " but the settings say " +
                    std::to_string(image_width(settings_.camera)) + "x" +
                    std::to_string(image_height(settings_.camera)),
                {settings_.source.string(), "Camera.width"});
  if (!depth.empty() && depth.size() != image.size()) {
    throw Error("System::track: depth image is " + std::to_string(depth.cols) + "x" +
                std::to_string(depth.rows) + ", the colour image " + std::to_string(image.cols) +
                "x" + std::to_string(image.rows));
  }
}

void System::account(const cv::Mat& image, const tracking::TrackingResult& r, double timestamp) {
  extract_ms_.push_back(r.extract_ms);
  track_ms_.push_back(r.track_ms);
  pose_ms_.push_back(r.pose_ms);
  local_map_ms_.push_back(r.local_map_ms);
  keyframe_ms_.push_back(r.keyframe_ms);
  decisions_.made += r.keyframe ? 1 : 0;
  decisions_.deferred += r.keyframe_deferred ? 1 : 0;
  decisions_.refused_busy += r.keyframe_refused_busy ? 1 : 0;
  if (observer_ != nullptr && observer_->wants_frame(timestamp)) notify(image, r, timestamp);
}

void System::notify(const cv::Mat& image, const tracking::TrackingResult& r, double timestamp) {
  FrameSnapshot s;
  s.index = extract_ms_.size() - 1;
  s.timestamp = timestamp;
  s.state = r.state == tracking::TrackingState::kOk
                ? (r.relocalized ? ObservedState::kRelocalized : ObservedState::kTracking)
                : (r.state == tracking::TrackingState::kLost ? ObservedState::kLost
                                                             : ObservedState::kInit);
  if (r.state == tracking::TrackingState::kOk) {
    s.world_from_cam = r.cam_from_world.inverse();
    fill_keypoints(tracker_->last_frame(), s);
  }
  s.keyframe = r.keyframe;
  s.inliers = r.inliers;
  s.track_ms = r.extract_ms + r.track_ms;
  s.image = image.clone();
  s.rgb = options_.tracking.rgb_input;
  observer_->on_frame(std::move(s));
}

Trajectory System::trajectory() const {
  std::lock_guard lock(shared_->mutex);
  Trajectory out;
  if (!tracker_) return out;
  for (const auto& rec : tracker_->records()) {
    if (!rec.tracked) continue;
    const auto ref = shared_->map.keyframe_pose(rec.reference);
    if (!ref) continue;
    out.push_back({rec.timestamp, (rec.cam_from_reference * *ref).inverse()});
  }
  return out;
}

Trajectory System::keyframe_trajectory() const {
  std::lock_guard lock(shared_->mutex);
  std::vector<const map::Keyframe*> kfs;
  for (const auto& [id, kf] : shared_->map.keyframes())
    kfs.push_back(&kf);
  std::sort(kfs.begin(), kfs.end(), [](const auto* a, const auto* b) { return a->id < b->id; });
  Trajectory out;
  for (const auto* kf : kfs)
    out.push_back({kf->frame.timestamp, kf->cam_from_world().inverse()});
  return out;
}

SystemSummary System::summary() const {
  SystemSummary s;
  s.frames = extract_ms_.size();
  if (tracker_) {
    for (const auto& rec : tracker_->records())
      s.tracked += rec.tracked ? 1 : 0;
  }
  s.lost = s.frames - s.tracked;
  {
    std::lock_guard lock(shared_->mutex);
    s.keyframes = shared_->map.keyframe_count();
    s.points = shared_->map.point_count();
  }
  s.relocalizations = tracker_ ? tracker_->relocalizations() : 0;
  if (shared_->estimate_readout) s.estimated_readout = shared_->readout.load();
  s.mapping = mapper_->stats();
  if (loop_closer_) s.loop = loop_closer_->stats();
  std::vector<double> total(extract_ms_.size());
  for (std::size_t i = 0; i < total.size(); ++i)
    total[i] = extract_ms_[i] + track_ms_[i];
  s.extract_ms = summarize(extract_ms_);
  s.track_ms = summarize(track_ms_);
  s.total_ms = summarize(total);
  s.extracted_ahead = extracted_ahead_;
  s.pose_ms = summarize(pose_ms_);
  s.local_map_ms = summarize(local_map_ms_);
  s.keyframe_ms = summarize(keyframe_ms_);
  s.keyframe_decisions = decisions_;
  return s;
}

std::unique_ptr<System> open_system(const settings::Settings& settings,
                                    const bow::Vocabulary& vocabulary, SystemOptions options,
                                    const std::filesystem::path& load_map,
                                    const mapdb::ProgressFn& progress) {
  if (load_map.empty()) return std::make_unique<System>(settings, vocabulary, options);
  mapdb::LoadOptions load;
  load.progress = progress;
  return std::make_unique<System>(settings, vocabulary, options,
                                  mapdb::load_map(load_map, vocabulary, load));
}

}  // namespace coloc::slam::system
