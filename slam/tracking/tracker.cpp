#include "slam/tracking/tracker.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <unordered_map>
#include <unordered_set>

#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/frame/rolling_shutter.hpp"
#include "slam/map/shutter.hpp"
#include "slam/matching/pose_support.hpp"
#include "slam/matching/search.hpp"

namespace coloc::slam::tracking {
namespace {
constexpr double kDegPerRad = 180.0 / std::numbers::pi;
}  // namespace

const char* to_string(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized:
      return "not initialized";
    case TrackingState::kOk:
      return "ok";
    case TrackingState::kLost:
      return "lost";
  }
  return "?";
}

void TrackingOptions::check() const {
  if (min_init_points < 10) throw Error("TrackingOptions.min_init_points must be >= 10");
  if (!(motion_search_radius > 0.0))
    throw Error("TrackingOptions.motion_search_radius must be > 0");
  if (!(local_search_th > 0.0)) throw Error("TrackingOptions.local_search_th must be > 0");
  if (!(reference_ratio > 0.0 && reference_ratio <= 1.0))
    throw Error("TrackingOptions.reference_ratio must be in (0, 1]");
  if (min_local_inliers < 10) throw Error("TrackingOptions.min_local_inliers must be >= 10");
  if (min_frames_between_keyframes < 0)
    throw Error("TrackingOptions.min_frames_between_keyframes must be >= 0");
  if (!(early_keyframe_rotation_deg >= 0.0))
    throw Error("TrackingOptions.early_keyframe_rotation_deg must be >= 0");
  if (!(early_keyframe_translation_m >= 0.0))
    throw Error("TrackingOptions.early_keyframe_translation_m must be >= 0");
  if (min_frames_between_slow_keyframes < 0)
    throw Error("TrackingOptions.min_frames_between_slow_keyframes must be >= 0");
  if (max_frames_between_keyframes < 1)
    throw Error("TrackingOptions.max_frames_between_keyframes must be >= 1");
  if (max_local_keyframes < 1) throw Error("TrackingOptions.max_local_keyframes must be >= 1");
  if (!(rolling_shutter_keep_ratio > 0.0 && rolling_shutter_keep_ratio <= 1.0))
    throw Error("TrackingOptions.rolling_shutter_keep_ratio must be in (0, 1]");
  if (!(rolling_shutter_rate_sigma >= 0.0))
    throw Error("TrackingOptions.rolling_shutter_rate_sigma must be >= 0");
  if (!(reloc_gate_seconds >= 0.0)) throw Error("TrackingOptions.reloc_gate_seconds must be >= 0");
  if (!(reloc_gate_m >= 0.0)) throw Error("TrackingOptions.reloc_gate_m must be >= 0");
  if (!(reloc_gate_speed >= 0.0)) throw Error("TrackingOptions.reloc_gate_speed must be >= 0");
  if (!(reloc_gate_localizing_m >= 0.0))
    throw Error("TrackingOptions.reloc_gate_localizing_m must be >= 0");
  if (!(weak_reference_ratio == 0.0 || weak_reference_ratio >= 1.0))
    throw Error("TrackingOptions.weak_reference_ratio must be 0 (off) or at least 1");
  if (!(motion_prior_sigma_m >= 0.0))
    throw Error("TrackingOptions.motion_prior_sigma_m must be >= 0 (0: off)");
  if (motion_prior_max_matches < 0)
    throw Error("TrackingOptions.motion_prior_max_matches must be >= 0");
  if (!(keyframe_defer_ratio >= 0.0 && keyframe_defer_ratio < 1.0))
    throw Error("TrackingOptions.keyframe_defer_ratio must be in [0, 1)");
  if (keyframe_defer_max < 0) throw Error("TrackingOptions.keyframe_defer_max must be >= 0");
  if (!(keyframe_defer_deviation_deg >= 0.0))
    throw Error("TrackingOptions.keyframe_defer_deviation_deg must be >= 0 (0 = off)");
  if (keyframe_defer_deviation_max < 0)
    throw Error("TrackingOptions.keyframe_defer_deviation_max must be >= 0");
  if (reloc_pause_min_inliers < 0)
    throw Error("TrackingOptions.reloc_pause_min_inliers must be >= 0");
  if (keyframe_depth_factor < 0 || keyframe_depth_factor > map::KeyframeDepth::kMaxFactor)
    throw Error("TrackingOptions.keyframe_depth_factor must be in 0.." +
                std::to_string(map::KeyframeDepth::kMaxFactor) + " (0 = none)");
  relocalization.check();
}

Tracker::Tracker(map::SharedMap& map, map::KeyframeSink* sink, const bow::Vocabulary& vocabulary,
                 std::shared_ptr<const frame::FrameGeometry> geometry,
                 const features::ExtractorOptions& extractor, const Camera& camera,
                 TrackingOptions options)
    : shared_(map),
      sink_(sink),
      vocabulary_(vocabulary),
      geometry_(std::move(geometry)),
      camera_(camera),
      options_(options),
      extraction_(extractor, camera, options.rgb_input) {
  options_.check();
  geometry_->check();
  std::lock_guard lock(shared_.mutex);
  if (!sink_ && shared_.map.keyframe_count() == 0)
    throw Error("Tracker: localization only (no keyframe sink) needs a map with keyframes");
  // A map that already holds keyframes (a loaded one) has its frame of reference: the first
  // frame relocalizes into it instead of starting a new map, and mapping then extends it.
  if (shared_.map.keyframe_count() > 0) state_ = TrackingState::kLost;
}

// Images that do not belong to this camera are an input error (coloc::Error with the sizes),
// not an OpenCV assertion deep in extraction: callers replaying files skip the frame and name
// it, as they do for unreadable files.
void check_images(const cv::Mat& image, const cv::Mat& depth, const Camera& camera) {
  if (image.empty()) throw Error("empty image");
  if (image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
    throw Error("image is not 8-bit grey, colour or colour + alpha");
  }
  const auto size_text = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
  const int width = image_width(camera), height = image_height(camera);
  if (width > 0 && height > 0 && (image.cols != width || image.rows != height)) {
    throw Error("image is " + size_text(image.cols, image.rows) + ", the camera's " +
                    size_text(width, height),
                {.field = "Camera.width/Camera.height"});
  }
  if (!depth.empty() && depth.size() != image.size()) {
    throw Error("depth image is " + size_text(depth.cols, depth.rows) + ", the colour image " +
                size_text(image.cols, image.rows));
  }
}

void Tracker::compute_bow(frame::Frame& f) const {
  if (f.bow.empty()) vocabulary_.transform(f.features.descriptors, f.bow, f.feature_vector);
}

TrackingResult Tracker::track(const cv::Mat& image, const cv::Mat& depth, double timestamp) {
  check_images(image, depth, camera_);
  return track_features(depth, timestamp, extraction_(image));
}

TrackingResult Tracker::track(const cv::Mat& image, const cv::Mat& depth, double timestamp,
                              ImageFeatures extracted) {
  check_images(image, depth, camera_);
  if (extracted.grey.size() != image.size())
    throw Error("tracking was handed the features of another image (of " +
                std::to_string(extracted.grey.cols) + "x" + std::to_string(extracted.grey.rows) +
                " pixels)");
  return track_features(depth, timestamp, std::move(extracted));
}

TrackingResult Tracker::track_features(const cv::Mat& depth, double timestamp,
                                       ImageFeatures extracted) {
  TrackingResult result;
  result.extract_ms = extracted.extract_ms;
  const cv::Mat grey = extracted.grey;
  current_ =
      frame::Frame(frame_ids_.next(), timestamp, std::move(extracted.features), depth, geometry_);
  current_depth_ = depth;
  Stopwatch watch;
  pose_rate_ = Eigen::Vector3d::Zero();
  centre_prior_.reset();
  bool make_keyframe = false;
  {
    std::lock_guard lock(shared_.mutex);
    bool ok = false;
    if (state_ == TrackingState::kNotInitialized) {
      ok = initialize();
      if (ok) result.keyframe = true;
    } else {
      ok = track_frame(grey.rows, timestamp, result, make_keyframe);
    }
    if (state_ != TrackingState::kNotInitialized) record_frame(ok);
    if (make_keyframe) {
      Stopwatch stage;
      create_keyframe();
      result.keyframe_ms += stage.elapsed_ms();
    }
  }
  if (sink_ && (result.keyframe || make_keyframe)) {
    sink_->push({reference_, grey.clone()});
    ++keyframes_made_;
    if (options_.wait_for_sink ||
        (shared_.estimate_readout && keyframes_made_ <= options_.readout_settle_keyframes)) {
      const Stopwatch wait;
      sink_->wait_idle();
      result.wait_ms = wait.elapsed_ms();
    }
  }
  result.keyframe = result.keyframe || make_keyframe;
  result.state = state_;
  result.cam_from_world = current_.cam_from_world;
  result.inliers = matches_inliers_;
  if (result.state == TrackingState::kOk) {
    matching::drop_outliers(current_);
    last_ = current_;
  } else {
    last_ = frame::Frame();
  }
  current_depth_.release();
  result.track_ms = watch.elapsed_ms() - result.wait_ms;
  spdlog::debug("tracking: frame {} state {} inliers {} keyframe {}", current_.id.value(),
                to_string(state_), matches_inliers_, result.keyframe);
  return result;
}

bool Tracker::track_frame(int image_rows, double timestamp, TrackingResult& result,
                          bool& make_keyframe) {
  Stopwatch stage;
  bool ok = false;
  if (state_ == TrackingState::kOk) {
    ok = track_from_last_frame();
  } else {
    ok = relocalize();
    result.relocalized = ok;
  }
  result.pose_ms = stage.elapsed_ms();
  stage.restart();
  if (ok) {
    ok = track_local_map();
    if (!ok)
      spdlog::debug("tracking: frame {} local map inliers {}", current_.id.value(),
                    matches_inliers_);
  } else if (state_ == TrackingState::kOk) {
    spdlog::debug("tracking: frame {} lost (motion model and reference keyframe failed)",
                  current_.id.value());
  }
  if (ok) {
    deviation_deg_ = 0.0;
    if (has_velocity_ && last_.has_pose) {
      const SE3 predicted = motion_since_last() * last_.cam_from_world;
      deviation_deg_ = rotation_distance(current_.cam_from_world, predicted) * kDegPerRad;
    }
    if (last_.has_pose) {
      // The motion as tracked, before the rolling-shutter refinement below moves the pose.
      const SE3 current_from_last = current_.cam_from_world * last_.cam_from_world.inverse();
      recent_motion_.push_front({current_from_last.so3().log().norm() * kDegPerRad,
                                 current_from_last.translation().norm()});
      const auto window =
          static_cast<std::size_t>(std::max(options_.min_frames_between_slow_keyframes, 1));
      if (recent_motion_.size() > window) recent_motion_.resize(window);
      refine_rolling_shutter(image_rows);
      velocity_ = current_.cam_from_world * last_.cam_from_world.inverse();  // after the refinement
      velocity_dt_ = current_.timestamp - last_.timestamp;
      has_velocity_ = true;
    }
    result.local_map_ms = stage.elapsed_ms();
    stage.restart();
    const KeyframeNeed need = need_keyframe();
    result.keyframe_refused_busy = need == KeyframeNeed::kMapperBusy;
    if (need == KeyframeNeed::kYes) {
      result.keyframe_deferred = defer_keyframe();
      make_keyframe = !result.keyframe_deferred;
    } else {
      keyframes_deferred_ = 0;  // a streak of deferrals ends where no keyframe was needed
    }
    result.keyframe_ms = stage.elapsed_ms();
    recent_inliers_ = {matches_inliers_, recent_inliers_[0], recent_inliers_[1]};
    const Eigen::Vector3d centre = current_.cam_from_world.inverse().translation();
    const double dt = last_.has_pose ? timestamp - last_.timestamp : 0.0;
    if (dt > 0.0) {
      // Smoothed over a few frames: one interval's centre moves by millimetres of noise.
      const Eigen::Vector3d v = (centre - last_tracked_centre_) / dt;
      last_tracked_velocity_ = has_tracked_velocity_ ? 0.5 * (last_tracked_velocity_ + v) : v;
      has_tracked_velocity_ = true;
    } else {
      last_tracked_velocity_.setZero();
      has_tracked_velocity_ = false;
    }
    last_tracked_centre_ = centre;
    last_tracked_time_ = timestamp;
  } else {
    has_velocity_ = false;
    recent_inliers_ = {};
  }
  state_ = ok ? TrackingState::kOk : TrackingState::kLost;
  return ok;
}

void Tracker::refine_rolling_shutter(int image_rows) {
  const double dt = current_.timestamp - last_.timestamp;
  const bool estimated = shared_.estimate_readout;
  const double readout = estimated ? shared_.readout.load() : geometry_->readout;
  if (!(readout > 0.0 || estimated) || !(dt > 0.0)) return;
  // The rotation from the last frame to this one, tracked with the uncompensated keypoints: its
  // rate is the best estimate of the turn during this frame's readout (measured with `coloc eval
  // frame-limit`: the rate of the previous frame pair, one frame late, makes things worse).
  const SE3 current_from_last = current_.cam_from_world * last_.cam_from_world.inverse();
  const int before = static_cast<int>(current_.tracked_count());
  frame::Frame uncompensated = current_;
  const Eigen::Vector3d pose_rate = -current_from_last.so3().log() / dt;
  // With a known readout, the first keyframe takes the rate of the pair it starts: left
  // uncompensated, it is the one view the others are measured against while it is held fixed in
  // the first local BAs (sequential runs, our files: fr1/rpy 14.11 -> 13.19 mm, 7-Scenes 33.48 ->
  // 33.19). Not while the readout is estimated: with keyframes that carry their poses' rate
  // (add_current_keyframe), sequential fr1/rpy with the ORB-SLAM3 file from start frames 0-9
  // gave mean 15.79 mm, worst 20.0, against 15.13 and 17.5 without it (with the deviation rule,
  // keyframe_defer_deviation_deg; before it, the same comparison ended as far out as 85 mm).
  if (!estimated && keyframe_without_rate_.valid() && last_keyframe_frame_ == last_.id)
    map::set_keyframe_shutter_rate(shared_.map, keyframe_without_rate_, pose_rate, image_rows,
                                   readout);
  keyframe_without_rate_ = KeyframeId();
  current_.compensate_rolling_shutter(pose_rate, image_rows, readout);
  pose_rate_ = pose_rate;
  // Readout still 0 while it is estimated: only the rate is recorded, for local mapping.
  if (readout == 0.0) return;
  int after = optimize_pose(current_);
  if (options_.rolling_shutter_rate_sigma > 0.0) {
    // The two-pose rate is noisy (two poses' errors over 33 ms): refine it with what the rows'
    // shear in this image asks for, then compensate again from the raw keypoints.
    std::vector<frame::RateObservation> obs;
    const frame::RollingShutter shutter{readout, image_rows};
    for (std::size_t i = 0; i < current_.size(); ++i) {
      if (!current_.points[i].valid() || current_.outlier[i]) continue;
      const map::MapPoint* p = shared_.map.point(current_.points[i]);
      if (!p) continue;
      const auto& kp = uncompensated.features.keypoints[i];
      obs.push_back({current_.cam_from_world * p->position,
                     {kp.ux, kp.uy},
                     frame::row_time(kp.y, shutter),
                     1.0 / geometry_->scale_factors[static_cast<std::size_t>(kp.level)]});
    }
    const Eigen::Vector3d rate =
        frame::estimate_rotation_rate(obs, pose_rate, options_.rolling_shutter_rate_sigma,
                                      geometry_->fx, geometry_->fy, geometry_->cx, geometry_->cy);
    frame::Frame refined = uncompensated;
    refined.cam_from_world = current_.cam_from_world;
    refined.compensate_rolling_shutter(rate, image_rows, readout);
    after = optimize_pose(refined);
    current_ = std::move(refined);
  }
  // A poorly tracked (blurred) frame gives a wrong rate: the compensation is undone when it costs
  // inliers (a ratio below 0.8 let fr1/rpy diverge; 1.0 undid half of the useful ones).
  if (after < options_.rolling_shutter_keep_ratio * before) {
    const Eigen::Vector3d rate = current_.shutter_rate;
    current_ = std::move(uncompensated);
    // An estimated readout keeps the rate on record: a keyframe left at 0 ms while the others
    // follow the estimate would hold its points, and so the estimate, at 0.
    if (estimated) current_.compensate_rolling_shutter(rate, image_rows, 0.0);
  }
}

void Tracker::follow_reference_of_last_frame() {
  if (!last_.has_pose || records_.empty() || !records_.back().tracked) return;
  const FrameRecord& rec = records_.back();
  if (const auto ref = shared_.map.keyframe_pose(rec.reference))
    last_.cam_from_world = rec.cam_from_reference * *ref;
}

void Tracker::record_frame(bool tracked) {
  FrameRecord rec;
  rec.timestamp = current_.timestamp;
  rec.tracked = tracked;
  const map::Keyframe* ref = shared_.map.keyframe(reference_);
  if (tracked && ref) {
    rec.reference = reference_;
    rec.cam_from_reference = current_.cam_from_world * ref->cam_from_world().inverse();
  }
  // Localizing for hours must not grow memory: only the last record is kept then (the motion
  // model follows its reference keyframe).
  if (!options_.keep_records) records_.clear();
  records_.push_back(rec);
}

bool Tracker::initialize() {
  int with_depth = 0;
  for (std::size_t i = 0; i < current_.size(); ++i)
    with_depth += current_.has_depth(i) ? 1 : 0;
  if (with_depth < options_.min_init_points) return false;
  map::Map& m = shared_.map;
  current_.cam_from_world = SE3();
  current_.has_pose = true;
  const KeyframeId id = add_current_keyframe();
  for (std::size_t i = 0; i < current_.size(); ++i) {
    if (!current_.has_depth(i)) continue;
    const MapPointId p =
        m.add_point(current_.unproject_world(i), id, static_cast<std::uint32_t>(i)).id;
    current_.points[i] = p;
  }
  reference_ = id;
  last_keyframe_frame_ = current_.id;
  keyframe_without_rate_ = id;
  local_keyframes_ = {id};
  local_points_.clear();
  for (MapPointId p : current_.points)
    if (p.valid()) local_points_.push_back(p);
  state_ = TrackingState::kOk;
  matches_inliers_ = static_cast<int>(local_points_.size());
  spdlog::info("tracking: initialized with {} points", local_points_.size());
  return true;
}

SE3 scale_motion(const SE3& motion, double measured_dt, double dt) {
  constexpr double kSkipRatio = 1.6;
  constexpr double kMaxRatio = 5.0;
  if (!(measured_dt > 0.0) || !(dt > 0.0)) return motion;
  const double ratio = dt / measured_dt;
  if (ratio < kSkipRatio && ratio > 1.0 / kSkipRatio) return motion;
  return SE3::exp(motion.log() * std::min(ratio, kMaxRatio));
}

SE3 Tracker::motion_since_last() const {
  return scale_motion(velocity_, velocity_dt_, current_.timestamp - last_.timestamp);
}

bool Tracker::track_from_last_frame() {
  if (!shared_.map.keyframe(reference_)) update_local_map();
  follow_reference_of_last_frame();
  const SE3 motion = motion_since_last();
  if (has_velocity_ && options_.motion_prior_sigma_m > 0.0)
    centre_prior_ =
        optim::CentrePrior{.world_centre = (motion * last_.cam_from_world).inverse().translation(),
                           .sigma_m = options_.motion_prior_sigma_m};
  if (has_velocity_ && track_motion_model(motion)) return true;
  if (track_reference_keyframe()) return true;
  // Right after a relocalization there is no velocity yet, and the reference keyframe's BoW
  // matches can be too few (the relocalizing frame needed projection passes too): the last
  // frame's matches, projected from where it was, still find this one.
  return !has_velocity_ && last_.has_pose && track_motion_model(SE3());
}

bool Tracker::track_motion_model(const SE3& velocity) {
  const map::Map& m = shared_.map;
  current_.cam_from_world = velocity * last_.cam_from_world;
  current_.points.assign(current_.size(), MapPointId::invalid());
  int n = matching::search_from_last_frame(current_, last_, m, options_.motion_search_radius);
  if (n < 20) {
    current_.points.assign(current_.size(), MapPointId::invalid());
    n = matching::search_from_last_frame(current_, last_, m, 2.0 * options_.motion_search_radius);
  }
  if (n < 20) return false;
  if (n >= options_.motion_prior_max_matches) centre_prior_.reset();  // a sharp frame
  optimize_pose(current_);
  spdlog::debug("tracking: frame {} motion model {} matches", current_.id.value(), n);
  int kept = 0;
  for (std::size_t i = 0; i < current_.size(); ++i) {
    if (current_.points[i].valid() && !current_.outlier[i]) ++kept;
  }
  matching::drop_outliers(current_);
  return kept >= 10;
}

int Tracker::optimize_pose(frame::Frame& frame) const {
  return matching::optimize_frame_pose(frame, shared_.map, {},
                                       centre_prior_ ? &*centre_prior_ : nullptr);
}

bool Tracker::track_reference_keyframe() {
  map::Map& m = shared_.map;
  map::Keyframe* ref = m.keyframe(reference_);
  if (!ref || !last_.has_pose) return false;
  compute_bow(current_);
  if (ref->frame.feature_vector.entries.empty()) {
    if (!sink_) return false;  // localizing: the map is read only (a loaded map has them)
    compute_bow(ref->frame);
  }
  current_.points.assign(current_.size(), MapPointId::invalid());
  if (matching::search_by_bow(*ref, current_, m) < 15) return false;
  current_.cam_from_world = last_.cam_from_world;
  const int inliers = optimize_pose(current_);
  matching::drop_outliers(current_);
  return inliers >= 10;
}

bool Tracker::relocalize() {
  compute_bow(current_);
  const map::Map& m = shared_.map;
  reloc::RelocalizationPrior prior;
  const double dt = last_tracked_time_ ? current_.timestamp - *last_tracked_time_ : 0.0;
  if (last_tracked_time_ && dt >= 0.0 && dt < options_.reloc_gate_seconds) {
    prior.world_centre = last_tracked_centre_ + last_tracked_velocity_ * dt;
    // A mapper may close a loop meanwhile and move the map under the last pose; a localizer's
    // map stays put.
    const double base = sink_ ? options_.reloc_gate_m : options_.reloc_gate_localizing_m;
    prior.max_distance_m = base + options_.reloc_gate_speed * dt;
    if (m.keyframe(reference_)) {
      prior.keyframes.push_back(reference_);
      for (KeyframeId k : m.covisible(reference_, options_.relocalization.max_candidates))
        prior.keyframes.push_back(k);
    }
  }
  const auto r = reloc::relocalize(current_, m, shared_.database, options_.relocalization, prior);
  if (r.implausible > 0) {
    spdlog::info(
        "tracking: relocalization at frame {}: {} candidate(s) refused, the nearest {:.2f} m from "
        "where the camera was heading {:.2f} s after its last tracked frame (at most {:.2f} m)",
        current_.id.value(), r.implausible, r.nearest_implausible_m, dt, prior.max_distance_m);
  }
  if (!r.success) return false;
  reference_ = r.keyframe;
  last_reloc_frame_ = current_.id;
  ++relocalizations_;
  spdlog::info(
      "tracking: relocalized at frame {} against keyframe {} ({} inliers: bow {}, epnp {}, "
      "optimized {}, wide pass +{} -> {}, narrow pass +{} -> {})",
      current_.id.value(), r.keyframe.value(), r.inliers, r.bow_matches, r.pnp_inliers,
      r.optimized_inliers, r.wide_pass_matches, r.wide_pass_inliers, r.narrow_pass_matches,
      r.narrow_pass_inliers);
  return true;
}

void Tracker::update_local_map() {
  const map::Map& m = shared_.map;
  std::unordered_map<KeyframeId, int> counts;
  for (std::size_t i = 0; i < current_.size(); ++i) {
    const map::MapPoint* p = current_.points[i].valid() ? m.point(current_.points[i]) : nullptr;
    if (!p) continue;
    for (const auto& [k, idx] : p->observations)
      ++counts[k];
  }
  if (counts.empty() && m.keyframe(reference_)) counts[reference_] = 1;
  std::vector<KeyframeId> local;
  std::unordered_set<KeyframeId> in_local;
  KeyframeId best;
  int best_count = 0;
  for (const auto& [k, c] : counts) {
    if (!m.keyframe(k)) continue;
    local.push_back(k);
    in_local.insert(k);
    if (c > best_count || (c == best_count && k > best)) {
      best_count = c;
      best = k;
    }
  }
  std::sort(local.begin(), local.end(),
            [&](KeyframeId a, KeyframeId b) { return counts[a] > counts[b]; });
  const std::size_t first_ring = local.size();
  for (std::size_t i = 0; i < first_ring && local.size() < options_.max_local_keyframes; ++i) {
    const map::Keyframe* kf = m.keyframe(local[i]);
    std::vector<KeyframeId> extra = m.covisible(local[i], 10);
    for (KeyframeId c : kf->children)
      extra.push_back(c);
    if (kf->parent.valid()) extra.push_back(kf->parent);
    for (KeyframeId k : extra) {
      if (m.keyframe(k) && in_local.insert(k).second) local.push_back(k);
    }
  }
  if (best.valid()) reference_ = best;
  local_keyframes_ = std::move(local);
  std::unordered_set<MapPointId> seen;
  local_points_.clear();
  for (KeyframeId k : local_keyframes_) {
    for (MapPointId p : m.keyframe(k)->frame.points) {
      if (p.valid() && seen.insert(p).second) local_points_.push_back(p);
    }
  }
}

bool Tracker::track_local_map() {
  map::Map& m = shared_.map;
  update_local_map();
  // Points already matched count as found (and visible); the rest are searched.
  std::unordered_set<MapPointId> matched;
  for (std::size_t i = 0; i < current_.size(); ++i) {
    if (current_.points[i].valid()) matched.insert(current_.points[i]);
  }
  // The visible/found statistics belong to the map's maintenance (point culling): a localizer
  // (no sink) only reads the map, so several can share it and it stays as it was saved.
  const bool maintain = sink_ != nullptr;
  if (maintain) {
    for (MapPointId p : matched) {
      if (map::MapPoint* mp = m.point(p)) ++mp->visible;
    }
  }
  std::vector<MapPointId> candidates;
  for (MapPointId p : local_points_)
    if (!matched.count(p)) candidates.push_back(p);
  const bool recent_reloc =
      last_reloc_frame_.valid() && current_.id.value() < last_reloc_frame_.value() + 2;
  std::vector<MapPointId> visible;
  matching::search_local_points(current_, candidates, m,
                                recent_reloc ? 5.0 : options_.local_search_th,
                                maintain ? &visible : nullptr);
  for (MapPointId p : visible)
    ++m.point(p)->visible;
  optimize_pose(current_);
  matches_inliers_ = 0;
  for (std::size_t i = 0; i < current_.size(); ++i) {
    if (!current_.points[i].valid() || current_.outlier[i]) continue;
    map::MapPoint* p = m.point(current_.points[i]);
    if (!p) continue;
    if (maintain) ++p->found;
    ++matches_inliers_;
  }
  current_.has_pose = true;
  const bool after_reloc =
      last_reloc_frame_.valid() &&
      current_.id.value() < last_reloc_frame_.value() +
                                static_cast<std::uint64_t>(options_.max_frames_between_keyframes);
  return matches_inliers_ >=
         (after_reloc ? options_.min_local_inliers_after_reloc : options_.min_local_inliers);
}

}  // namespace coloc::slam::tracking
