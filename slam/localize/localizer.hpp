#pragma once
// Localization only (ORB-SLAM's localization mode) in a saved, fixed map: per frame the motion
// model, projection search, pose optimization and local-map tracking over the map's
// covisibility; relocalization (BoW over the whole map, EPnP-RANSAC, two projection passes) at
// a cold start (the first frame may be anywhere in the map) and after loss; between a loss and
// the next relocalization, visual odometry from the last localized frame for a few seconds
// (odometry_bridge.hpp). No keyframes, no
// points, no local mapping thread: the map is never modified (not even the points'
// visible/found statistics), so it can be shared read-only and several localizers can run on
// one map.
//
// Frames: poses are world_from_cam in the map's frame (mapdb::MapMetadata::frame_name, "slam"
// until registration moves the map into the scan's frame), metres and seconds.
//
// Threads: localize() from one thread per Localizer. Localizers sharing a LocalizationMap take
// its SharedMap::mutex in turn while they read the map (not while they extract features).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/ids.hpp"
#include "slam/core/se3.hpp"
#include "slam/features/orb_extractor.hpp"
#include "slam/localize/odometry_bridge.hpp"
#include "slam/localize/scan_anchor.hpp"
#include "slam/localize/time_histogram.hpp"
#include "slam/map/shared_map.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/settings/settings.hpp"
#include "slam/tracking/tracker.hpp"

namespace coloc::slam::localize {

// A map loaded for localization: the map and its BoW database behind one mutex, what the file
// says about itself, and the frame geometries its keyframes share. Never modified by a
// Localizer. Not movable (the mutex): hold it by unique_ptr.
struct LocalizationMap {
  map::SharedMap shared;
  mapdb::MapMetadata metadata;
  std::vector<std::shared_ptr<const frame::FrameGeometry>> geometries;
  std::size_t keyframes() const { return shared.map.keyframe_count(); }
  std::size_t points() const { return shared.map.point_count(); }
};

// Loads a map file (mapdb::load_map, BoW rebuilt with `vocabulary`) with what localization
// reads only: whatever `options` say, no keyframe depth images and no keyframe BoW vectors
// (mapdb::LoadOptions::keyframe_depth, keyframe_bow), so such a map is not one to save or
// register. Throws coloc::Error naming the file (and table) like load_map, or when the map
// holds no keyframe.
std::unique_ptr<LocalizationMap> load_localization_map(const std::filesystem::path& path,
                                                       const bow::Vocabulary& vocabulary,
                                                       const mapdb::LoadOptions& options = {});

// The settings the map was built with (metadata.settings: the settings file's text, which
// `coloc map --save` stores), parsed as load_settings parses a file; `map_path` names the map in
// errors. Throws coloc::Error naming the map file and "metadata.settings" when the map holds no
// settings or they do not parse.
settings::Settings settings_saved_in(const LocalizationMap& map,
                                     const std::filesystem::path& map_path);

// The numbers are the OSC `state` argument of /coloc/pose (fusion/osc.hpp). kOdometry: not
// localized in the map, the pose carried on from the last localized frame by visual odometry
// (odometry_bridge.hpp): it drifts, so a drift filter must not take it as a global measurement.
enum class LocalizationState : std::int32_t {
  kLost = 0,
  kTracking = 1,
  kRelocalized = 2,
  kOdometry = 3
};
const char* to_string(LocalizationState state);

struct LocalizerOptions {
  // Tracking thresholds (min_local_inliers, search radii, relocalization). The keyframe
  // criteria are unused: a localizer never makes keyframes.
  tracking::TrackingOptions tracking;
  // Must match the extractor the map was built with (its scale pyramid predicts levels).
  features::ExtractorOptions extractor;
  // Across views the map does not cover (max_frames 0: lost there instead).
  OdometryBridgeOptions odometry;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// The options a camera settings file gives: ORBextractor.*, Camera.RGB and the
// Coloc.tracking.* keys (slam/tuning/tuning.hpp). Throws coloc::Error naming the file and key.
LocalizerOptions options_from_settings(const settings::Settings& settings);

struct LocalizationResult {
  double timestamp = 0.0;  // seconds, the frame's (exposure) time
  LocalizationState state = LocalizationState::kLost;
  SE3 world_from_cam;  // map frame; valid unless state == kLost
  // Map points matched and kept by the pose optimization (kOdometry: the previous frame's
  // points that support the bridged pose).
  int inliers = 0;
  // Quality: RMS of the inliers' reprojection errors, level-0 undistorted pixels (0 when lost
  // or bridged).
  double reprojection_rms_px = 0.0;
  KeyframeId reference;  // the keyframe sharing most points with the frame (invalid when lost)
  // With a scan anchor (Localizer::anchor_to_scan): world_from_cam is the depth image aligned to
  // the scan, started from the visual pose; scan_rms_m its point-to-plane RMS over scan_inliers
  // depth samples. False when the alignment was refused (the visual pose is kept).
  bool scan_anchored = false;
  int scan_inliers = 0;
  double scan_rms_m = 0.0;
  // Wall time of this call: feature extraction, the rest of tracking, and in it the initial pose
  // (motion model / relocalization) and the local-map tracking; total = the whole call.
  double extract_ms = 0.0, track_ms = 0.0, pose_ms = 0.0, local_map_ms = 0.0, total_ms = 0.0;
  double anchor_ms = 0.0;  // the scan alignment (part of total)
};

struct LocalizerStats {
  // localized: in the map; bridged: kOdometry (neither localized nor lost).
  std::uint64_t frames = 0, localized = 0, bridged = 0, lost = 0;
  std::uint64_t relocalizations = 0;  // lost (or cold) -> localized transitions
  std::uint64_t anchored = 0;         // localized or bridged frames aligned to the scan
  // First localized frame: its index (0-based) and the wall time from the first frame's start.
  std::int64_t first_localized_frame = -1;
  double ms_to_first_pose = 0.0;
  TimeHistogram total_ms;   // per frame, extraction included (bounded memory)
  TimeHistogram anchor_ms;  // per frame the scan alignment ran on (accepted or refused)
};

class Localizer {
 public:
  // Borrows `map` and `vocabulary` (both must outlive the localizer). `settings` gives the
  // camera (with its distortion), depth (Camera.bf, ThDepth; required) and readout time; the
  // image size comes from Camera.width/height or else the first frame. Throws coloc::Error
  // naming the settings file and key, or the first invalid option.
  Localizer(LocalizationMap& map, const bow::Vocabulary& vocabulary,
            const settings::Settings& settings, LocalizerOptions options);
  ~Localizer();
  Localizer(const Localizer&) = delete;
  Localizer& operator=(const Localizer&) = delete;

  // `image`: 8-bit grey or colour in the settings' Camera.RGB order; `depth`: CV_32FC1 metres
  // registered to it (0 = invalid); `timestamp`: seconds. Throws coloc::Error for an empty
  // image or a size other than the first frame's (naming Camera.width).
  LocalizationResult localize(const cv::Mat& image, const cv::Mat& depth, double timestamp);

  // Forget the motion: the next frame relocalizes in the whole map (e.g. after a jump).
  void reset();

  // Anchors every localized or bridged pose to the scan (scan_anchor.hpp); null turns it off.
  // The anchor's frame must be the map's (a map registered to that scan). Shared: several
  // localizers may use one anchor.
  void anchor_to_scan(std::shared_ptr<const ScanAnchor> anchor);

  const LocalizerStats& stats() const { return stats_; }
  // The last frame's keypoints and matched points (for a viewer); empty when it was not
  // localized, null before the first frame. Valid until the next localize().
  const frame::Frame* last_frame() const { return tracker_ ? &tracker_->last_frame() : nullptr; }
  const LocalizationMap& map() const { return map_; }

 private:
  void start_tracking(int width, int height);
  double reprojection_rms() const;  // of the tracker's last frame (takes the map lock)
  // Replaces r's visual pose by the scan-anchored one when the alignment is accepted.
  void anchor(const cv::Mat& depth, LocalizationResult& r);

  LocalizationMap& map_;
  const bow::Vocabulary& vocabulary_;
  settings::Settings settings_;
  LocalizerOptions options_;
  std::shared_ptr<const frame::FrameGeometry> geometry_;
  std::unique_ptr<tracking::Tracker> tracker_;
  OdometryBridge bridge_;
  std::shared_ptr<const ScanAnchor> scan_anchor_;
  std::optional<DepthSampler> depth_sampler_;
  // The last anchored frame: its anchored and its visual pose (the next frame starts from the
  // first moved by the visual motion since); nullopt after a refusal or a loss.
  std::optional<std::pair<SE3, SE3>> last_anchored_;
  LocalizerStats stats_;
  bool was_localized_ = false;
  double first_frame_start_s_ = -1.0;  // steady clock, seconds
};

}  // namespace coloc::slam::localize
