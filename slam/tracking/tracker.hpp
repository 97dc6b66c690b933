#pragma once
// RGB-D tracking (ORB-SLAM2's Tracking), run in the caller's thread: initialization from the
// first frame with enough depth, constant-velocity motion model with projection search,
// fallback to the reference keyframe by BoW matching, relocalization when lost, local-map
// tracking, and the keyframe decision (ORB-SLAM's criteria with the RGB-D close-points rule).
// New keyframes (with their close-depth points) go into the map at once and their ids to the
// keyframe sink (local mapping). Without a sink the tracker localizes in the map it is given and
// never adds keyframes or points to it (localization only). Given a map that already holds
// keyframes, the tracker relocalizes into it first and (with a sink) continues it.
//
// Threads: track() is called from one thread; it holds SharedMap::mutex while it reads or
// writes the map, not while it extracts features.
#include <array>
#include <deque>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <vector>

#include "slam/bow/vocabulary.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/keyframe_sink.hpp"
#include "slam/map/shared_map.hpp"
#include "slam/reloc/relocalizer.hpp"
#include "slam/tracking/image_features.hpp"

namespace coloc::slam::tracking {

enum class TrackingState { kNotInitialized, kOk, kLost };
const char* to_string(TrackingState state);

struct TrackingOptions {
  int min_init_points = 500;  // keypoints with depth needed to initialize
  // Pixels at level 0. ORB-SLAM2 searches 15 for RGB-D (and monocular), 7 for stereo only; 7
  // here lost fr1/rpy's blurred fast turns (frames 105-118), where the motion model's prediction
  // is furthest off.
  double motion_search_radius = 15;
  double local_search_th = 3;  // local-map search radius factor (RGB-D)
  int min_local_inliers = 30;  // local-map inliers to stay tracked
  int min_local_inliers_after_reloc = 50;
  int max_frames_between_keyframes = 30;  // fps
  // ORB-SLAM takes a keyframe the frame needs (too few of the reference's points tracked)
  // before max_frames_between_keyframes only while local mapping is idle, so how many a run
  // makes depends on how fast the mapper is: our sequential replays (the mapper idle at every
  // frame) made 73 on fr1/rpy 180f where ORB-SLAM2 live makes 32-35, and every local BA window
  // grew with them (1.1 s median on the whole of fr1/rpy). Here that condition is "at least
  // min_frames_between_keyframes frames since the last keyframe", whatever the mapper is doing,
  // so replayed, paced and live runs decide alike. 4 frames (30 Hz), sequential fr1/rpy 180f
  // from start frames 0-7: ORB-SLAM3 file 31-36 keyframes instead of 47-84, ATE median 16.1
  // instead of 15.4 mm; our TUM1 file 32-36 instead of 70-90, 15.3 instead of 13.4 mm; local BA
  // median 123 instead of 377 ms, the run 3.6x faster (docs/results/mapping-speed.md). 3 frames
  // (37-46 keyframes) was not better: 17.0 and 13.9 mm. keyframe_needs_idle_mapper restores
  // ORB-SLAM's rule (with min_frames_between_keyframes 0).
  int min_frames_between_keyframes = 4;
  // ... but only for a camera that moved: over the last min_frames_between_slow_keyframes
  // frames, its path (frame to frame) turned early_keyframe_rotation_deg or went
  // early_keyframe_translation_m. A slower one waits min_frames_between_slow_keyframes frames.
  // Why: the "too few of the reference's points tracked" condition holds at nearly every frame
  // of a slow hand-held RGB-D sequence (a keyframe makes points of all its close keypoints, a
  // frame re-finds about 70 % of them), so the 4-frame gap alone set the keyframe rate there.
  // Sequential 7-Scenes 600f took a keyframe every 4-5 frames after 0.4-2.5 deg and 2-5 cm: 78
  // keyframes against ORB-SLAM2's 42-55; with this rule 55, ATE 33.99 against 33.90 mm. fr1/rpy
  // turns 5-20 deg between its keyframes and keeps its 35 (ATE median over start frames 0-7
  // 15.89 mm, unchanged). A fixed 5 or 6 frames for every camera cost fr1/rpy 24-26 % (median
  // 19.7, 20.0 mm), and so did measuring the motion since the last keyframe instead of over a
  // window (19.6 mm): fr1/rpy swings back and pauses, and the sharp frame at the end of a swing
  // is the keyframe it needs. docs/results/mapping-speed.md, sitting of 2026-11-28 afternoon.
  // min_frames_between_slow_keyframes <= min_frames_between_keyframes: off.
  double early_keyframe_rotation_deg = 4.0;
  double early_keyframe_translation_m = 0.10;
  int min_frames_between_slow_keyframes = 8;
  bool keyframe_needs_idle_mapper = false;
  int close_tracked_limit = 100;   // RGB-D rule: fewer close tracked points than this ...
  int close_untracked_limit = 70;  // ... and more close untracked ones => new keyframe
  // A keyframe is needed once the frame tracks fewer than reference_ratio x the reference
  // keyframe's points seen twice (ORB-SLAM's thRefRatio for RGB-D; 0.4 while the map has one
  // keyframe). Lower values were measured on 2026-11-29 (docs/results/mapping-speed.md): 0.65
  // takes the twin building from 230 to 208 keyframes at the same ATE, but fr1/rpy's start
  // frames 0-7 end at 16.1 mm median instead of 14.7, one of them at 44 mm.
  double reference_ratio = 0.75;
  int new_points_min = 100;  // new close points per keyframe (then stop at far depth)
  std::size_t max_local_keyframes = 80;
  // A keyframe anchors the map: its pose and the points unprojected from its depth stay until
  // a BA moves them, and a live mapper gets to that BA frames later. A frame tracked with fewer
  // than keyframe_defer_ratio x the inliers of the best of the 3 frames before it (motion blur
  // in a fast turn: fr1/rpy frames 110-118, poses off by 1-2 deg) does not become one; the next
  // frame is asked again, at most keyframe_defer_max times in a row. 0 = never defer.
  double keyframe_defer_ratio = 0.5;
  int keyframe_defer_max = 2;
  // A frame whose tracked rotation departs from the motion model's prediction by more than
  // keyframe_defer_deviation_deg is not made a keyframe either, up to
  // keyframe_defer_deviation_max frames in a row (0 = off). In fr1/rpy's blurred turn the true
  // rate changes by at most ~3 deg per frame, yet a frame tracked with ~50-100 inliers can land
  // 10-17 deg off the prediction; as a keyframe it unprojects its depth into points at that
  // pose, the frames after it track against them, and the run ends 20-85 mm off. Sequential
  // runs from start frames 0-9 of fr1/rpy (2026-11-27): ORB-SLAM3 file, max 22.8 -> 17.5 mm,
  // mean 15.71 -> 15.13; our TUM1 file, max 37.5 -> 18.8, mean 16.40 -> 14.45 (4 frames in a
  // row: 2 left the ORB-SLAM3 file's worst at 24.0). Never triggered on 7-Scenes or fr1/xyz.
  // A true snap is put off too: the twin room's 10 deg at frame 10, paced, 3.43 -> 3.67 mm (5.27
  // -> 4.11 without the readout key); limited to weakly tracked frames, fr1/rpy's worst start
  // frame with our TUM1 file went back to 37.5 mm.
  double keyframe_defer_deviation_deg = 6.0;
  int keyframe_defer_deviation_max = 4;
  // A keyframe made from a frame that tracked poorly (blurred after keyframe_defer_max
  // deferrals, or a view the map barely covered) is a poor reference: it holds few points seen
  // twice, so ORB-SLAM's ratio test (c2) stays false while frames track more than 0.75 x that
  // few, however much of the view is unmapped. On fr1/rpy a keyframe made at frame 54 from 78
  // inliers held keyframes off until frame 71 in 2 of 8 runs (28-31 keyframes, ATE 28 mm, against
  // 13-15 mm with 34-41). So a frame that tracks more than weak_reference_ratio x the inliers of
  // the frame its reference keyframe was made from replaces it. 0 = off. (Limited to keyframes
  // made from blurred frames, 6 of 8 fr1/rpy runs ended near 20 mm: the rule also helps after
  // keyframes made at the edge of the map.)
  double weak_reference_ratio = 2.0;
  // A new keyframe keeps the matches the frame's pose optimization called outliers, as ORB-SLAM2
  // does ("so that bundle adjustment will finally decide"; the next frame's tracking drops
  // them). Dropped, their keypoints get fresh depth points no other keyframe has seen, so the
  // reference keyframe holds fewer points seen twice and keyframes come less often. Measured on
  // fr1/rpy paced with the ORB-SLAM3 file: reference points 200 against ORB-SLAM2's 317, and
  // kept outliers take ATE from 50 to 27 mm median (10 runs; ORB-SLAM2 26.8; 37-45 keyframes).
  // Off by default because BA does not reject what it is handed reliably: in the synthetic box
  // room (ContinueMapping.SecondHalf...), whose repeated cell corners give 20 % wrong matches,
  // about half of them survive the BA (a point seen by one other keyframe splits the error) and
  // the one-go map goes from 2.8 to 10.3 mm, the continued one to 17 mm. Not giving those
  // keypoints new points instead (no duplicate) helped fr1/rpy without a readout time (24 mm)
  // but cost 3.5x with one (49 mm) and 7-Scenes 6 %: there a rejected match is mostly a bad
  // point, and the fresh point replaces it. Set `Coloc.tracking.keyframe_keeps_outliers: 1` for
  // fast-turning rolling-shutter footage without a readout time.
  bool keyframe_keeps_outliers = false;
  // Pose optimization of a weakly matched frame (the motion model's search found fewer than
  // motion_prior_max_matches) holds the camera centre near the model's prediction with this
  // sigma (metres; 0 = off): optim::CentrePrior. A blurred frame in a fast turn tracks 50-90
  // inliers, and what rotation they leave unsettled shows as translation: in fr1/rpy frames
  // 50-53 the centre stepped 4 cm per frame while the camera barely moved, the keyframe made at
  // frame 53 put its points at that pose, and the run ended at 54 mm instead of 15. A hand-held
  // camera departs from constant velocity by 0.5 a dt^2, 3 mm per 30 Hz frame at 5 m/s^2.
  // Rotation is left free. Only for weak frames: on every frame the prior is a filter whose
  // prediction comes from its own past estimates, and on the twin building's walk (150-300
  // matches a frame) it doubled the drift as tracked without loop closing, 14.8 -> 29.2 mm;
  // with the 150 gate that walk is untouched. Measured 2026-11-29 (docs/results/mapping-speed.md):
  // fr1/rpy ORB-SLAM3 file over start frames 0-7, median (max) 16.06 (19.44) off, 15.57 (17.23)
  // on every frame, 14.72 (16.80) gated; 7-Scenes 600f 33.99 / 32.79 / 32.72 mm. Sigma 5 mm
  // and 3 mm were no better (14.39 and 18.46 ungated), nor a gate of 100 (15.50, max 22.30).
  double motion_prior_sigma_m = 0.01;
  int motion_prior_max_matches = 150;
  // Rolling-shutter compensation is kept when the re-optimized pose keeps at least this share
  // of the frame's inliers.
  double rolling_shutter_keep_ratio = 0.9;
  // Prior sigma (rad/s) of the two-pose rotation rate when the rate is refined from the image's
  // row shear; 0 = use the two-pose rate as it is. (0.3 let fr1/rpy diverge in sequential runs.)
  double rolling_shutter_rate_sigma = 1.0;
  // After each new keyframe, wait until the sink has processed it: deterministic, slower (tests,
  // the --sequential runs that separate what tracking does from when).
  bool wait_for_sink = false;
  // While local mapping estimates an unknown rolling-shutter readout (settings without
  // Camera.readoutTime), wait for the sink after each of the first this many keyframes, as
  // wait_for_sink does. The estimate moves once per local BA; a tracker that outruns the mapper
  // (recorded frames read back to back: 4x real time) meets a sequence's first fast turns with
  // an estimate a few BAs behind, and below ~17 ms a partial compensation is worse than none.
  // With the ORB-SLAM3 TUM1 file on fr1/rpy, unpaced, 10 runs each: 0 keyframes 22.7 mm median
  // (std 3.0), 20 17.1 (0.6), 30 15.3 (0.9), 40 14.9 (0.8). A live camera (or frames paced as
  // one) must not wait long, but the first local BAs take a few milliseconds: paced, 16 runs
  // each, 0 keyframes 16.4 mm median (max 21.5), 10 14.9 (max 17.6), with no frame handed out
  // a frame interval late (pipeline::run_slam uses 30 and 10).
  std::size_t readout_settle_keyframes = 0;
  // Colour images are RGB (ORB-SLAM's Camera.RGB: 1), else BGR. Only the grey conversion uses it.
  bool rgb_input = false;
  // Keep a FrameRecord per frame (the trajectory); false keeps only the last one, so memory
  // stays flat over a long localization session.
  bool keep_records = true;
  // A relocalization soon after tracking was lost must land where the camera can have got to
  // since its last tracked frame: a place that only looks alike (repeated rooms and textures of
  // a building) is farther. Within reloc_gate_seconds of that frame the new camera centre may
  // be at most reloc_gate_m + reloc_gate_speed * dt from where the last frames' velocity takes
  // it in dt; later, or from a cold start, anywhere. (A 56-inlier relocalization 40 m away tore
  // a continued twin map apart.) A candidate keyframe whose pose lands outside is passed over
  // for the next one, and the keyframes around the last tracked place are tried first.
  double reloc_gate_seconds = 3.0;
  double reloc_gate_m = 0.5;  // metres (also covers a loop correction meanwhile)
  // Metres per second the camera can gain or lose meanwhile: a walking user stops or starts
  // within about 1 m/s. (Demo room under load: 2 m/s from the last centre accepted a 0.88 m
  // look-alike 0.47 s after the loss; the walk went at 0.42 m/s.)
  double reloc_gate_speed = 1.0;
  // The same for a localizer: its map does not move, so only the last pose's error and the
  // depth noise count. (Demo room, walk 1: a 59-inlier look-alike 1.0 m away, 0.27 s after the
  // last tracked frame, was inside 0.5 m + 2 m/s and put the walk 1.1 m off for 2 s.)
  double reloc_gate_localizing_m = 0.1;
  // ORB-SLAM makes no keyframe for max_frames_between_keyframes frames after a relocalization,
  // unless (ours) tracking is thinning out: fewer local-map inliers than this. A continued map
  // is left at once for unmapped space, where that pause lost tracking.
  int reloc_pause_min_inliers = 100;
  // A keyframe keeps its frame's depth image downsampled by this factor (map::KeyframeDepth;
  // 640 x 480 -> 160 x 120, ~38 KB per keyframe at 4), so that a saved map registers to a scan
  // without the recording it was built from. 0: keep none.
  int keyframe_depth_factor = 4;
  reloc::RelocalizationOptions relocalization;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// The constant-velocity model over a frame interval other than the one the motion was measured
// over: `motion` (current_from_last over measured_dt seconds) scaled along its twist to dt. A
// localizer that falls behind a live camera skips frames (under load 2-4 intervals between the
// frames it tracks), and the motion of one interval predicts a third of the way: the search
// window misses and tracking is lost. Intervals within a factor 1.6 of each other keep the
// motion as measured, as ORB-SLAM does: recorded timestamps jitter (TUM fr1's between 27 and
// 40 ms, ratios up to 1.46, while the camera runs at a steady 30 Hz; scaling by them put
// fr1/rpy's starts 3 and 5 at 24-32 mm instead of 15-17). The ratio is capped at 5 (a longer
// gap is a relocalization's to bridge).
SE3 scale_motion(const SE3& motion, double measured_dt, double dt);

struct TrackingResult {
  TrackingState state = TrackingState::kNotInitialized;
  SE3 cam_from_world;  // valid when state == kOk
  int inliers = 0;
  bool keyframe = false;
  // The frame needed a keyframe but it was put off (TrackingOptions::keyframe_defer_ratio,
  // keyframe_defer_deviation_deg), or refused because three were already queued for the mapper.
  bool keyframe_deferred = false;
  bool keyframe_refused_busy = false;
  bool relocalized = false;
  double extract_ms = 0.0, track_ms = 0.0;  // feature extraction, the rest of tracking
  // Stages of track_ms: initial pose (motion model / reference keyframe / relocalization),
  // local-map tracking, keyframe decision and creation.
  double pose_ms = 0.0, local_map_ms = 0.0, keyframe_ms = 0.0;
  // Waiting for the keyframe sink after a keyframe (wait_for_sink, readout_settle_keyframes):
  // the source's choice to let mapping catch up, not tracking's work, so not in track_ms.
  double wait_ms = 0.0;
};

// A frame's pose relative to its reference keyframe (ORB-SLAM's trajectory bookkeeping: the
// final pose follows later optimizations of the keyframe).
struct FrameRecord {
  double timestamp = 0.0;
  KeyframeId reference;
  SE3 cam_from_reference;
  bool tracked = false;
};

class Tracker {
 public:
  // `map`, `vocabulary` and `sink` must outlive the tracker. `sink` null: localization only, in
  // a map that must already hold keyframes (coloc::Error otherwise). When the map holds
  // keyframes (loaded, or localization only) the first frame relocalizes into it; with a sink,
  // tracking then extends that map (continue mapping: one frame of reference).
  Tracker(map::SharedMap& map, map::KeyframeSink* sink, const bow::Vocabulary& vocabulary,
          std::shared_ptr<const frame::FrameGeometry> geometry,
          const features::ExtractorOptions& extractor, const Camera& camera,
          TrackingOptions options);

  // `image`: 8-bit grey, or colour in the order options.rgb_input says; `depth`: CV_32FC1 metres
  // registered to it (0 = invalid).
  TrackingResult track(const cv::Mat& image, const cv::Mat& depth, double timestamp);
  // The same with the image's features extracted beforehand, by a FeatureExtraction made from
  // extraction_settings() (on another thread: slam/pipeline/extract_ahead.hpp).
  TrackingResult track(const cv::Mat& image, const cv::Mat& depth, double timestamp,
                       ImageFeatures extracted);

  TrackingState state() const { return state_; }
  const std::vector<FrameRecord>& records() const { return records_; }
  // The last frame tracked (its pose, keypoints and inlier matches in `points`), empty after a
  // frame that was not. Valid until the next track().
  const frame::Frame& last_frame() const { return last_; }
  // The frame of the last track() call, tracked or not: its features and keypoint depths (a
  // localizer bridges a lost frame by odometry from them).
  const frame::Frame& current_frame() const { return current_; }
  int relocalizations() const { return relocalizations_; }

 private:
  // track() once the images are checked and the features extracted.
  TrackingResult track_features(const cv::Mat& depth, double timestamp, ImageFeatures extracted);
  bool initialize();
  // One frame of an initialized tracker (motion model / reference keyframe / relocalization,
  // then the local map); sets state_, the stage times and whether to make a keyframe.
  bool track_frame(int image_rows, double timestamp, TrackingResult& result, bool& make_keyframe);
  // Projects the last frame's matches from velocity * last pose (current_from_last).
  // Motion model, else the reference keyframe, else (just relocalized) zero motion.
  bool track_from_last_frame();
  bool track_motion_model(const SE3& velocity);
  // The motion model's current_from_last (scale_motion of velocity_).
  SE3 motion_since_last() const;
  // optimize_frame_pose() of `frame` with the motion model's centre prior, when there is one.
  int optimize_pose(frame::Frame& frame) const;
  bool track_reference_keyframe();
  bool relocalize();
  bool track_local_map();
  void update_local_map();
  enum class KeyframeNeed { kNo, kYes, kMapperBusy };
  KeyframeNeed need_keyframe() const;
  // Frames since the last keyframe before the current frame may be an early keyframe
  // (TrackingOptions::min_frames_between_slow_keyframes).
  int min_frames_for_keyframe() const;
  // A needed keyframe is put off when this frame tracked far worse than the ones before it
  // (TrackingOptions::keyframe_defer_ratio) or far off the motion model's prediction
  // (keyframe_defer_deviation_deg); counts the deferrals in a row.
  bool defer_keyframe();
  void create_keyframe();
  // Inserts current_ (with its BoW vector) into the map as a new keyframe.
  KeyframeId add_current_keyframe();
  void compute_bow(frame::Frame& frame) const;
  // Rolling shutter: compensates current_'s keypoints with the rotation rate from last_ to
  // current_ and re-optimizes the pose (no-op for a global-shutter camera).
  void refine_rolling_shutter(int image_rows);
  // ORB-SLAM2's UpdateLastFrame: the last frame keeps its pose relative to its reference
  // keyframe, which local BA or a loop correction may have moved since (map lock held).
  void follow_reference_of_last_frame();
  void record_frame(bool tracked);  // appends current_ to records_ (map lock held)

  map::SharedMap& shared_;
  map::KeyframeSink* sink_;
  const bow::Vocabulary& vocabulary_;
  std::shared_ptr<const frame::FrameGeometry> geometry_;
  Camera camera_;
  TrackingOptions options_;
  FeatureExtraction extraction_;

  IdIssuer<FrameId> frame_ids_;
  TrackingState state_ = TrackingState::kNotInitialized;
  frame::Frame current_, last_;
  // current_'s depth image (CV_32FC1 metres; the caller's, not copied), for the keyframe made
  // from it (add_current_keyframe); released when track() returns.
  cv::Mat current_depth_;
  SE3 velocity_;              // current_from_last of the last two tracked frames
  double velocity_dt_ = 0.0;  // seconds between those two frames
  // Where the motion model puts current_'s centre (TrackingOptions::motion_prior_sigma_m).
  std::optional<optim::CentrePrior> centre_prior_;
  bool has_velocity_ = false;
  KeyframeId reference_;
  FrameId last_keyframe_frame_;
  FrameId last_reloc_frame_;
  int matches_inliers_ = 0;
  std::size_t keyframes_made_ = 0;       // pushed to the sink
  std::array<int, 3> recent_inliers_{};  // of the last tracked frames, newest first
  int keyframes_deferred_ = 0;           // in a row (keyframe_defer_max)
  // Degrees between current_'s tracked rotation and the motion model's prediction (0 without
  // a velocity).
  double deviation_deg_ = 0.0;
  // Degrees and metres from each tracked frame to the next, newest first, over the last
  // min_frames_between_slow_keyframes frames (TrackingOptions::early_keyframe_rotation_deg).
  std::deque<std::pair<double, double>> recent_motion_;
  // The last keyframe this tracker made, and the inliers of the frame it was made from.
  KeyframeId last_keyframe_;
  int last_keyframe_inliers_ = 0;
  // The map's first keyframe until the next frame gives it a rotation rate (it had no tracked
  // frame before it; refine_rolling_shutter).
  KeyframeId keyframe_without_rate_;
  // The rotation rate between the last tracked frame and this one (rad/s, camera frame; zero
  // when this frame has none): what a keyframe made from it records while the readout is
  // estimated (add_current_keyframe).
  Eigen::Vector3d pose_rate_ = Eigen::Vector3d::Zero();
  // Camera centre, its velocity (m/s, world; zero after a frame that followed no tracked one)
  // and time of the last tracked frame: the relocalization gate.
  Eigen::Vector3d last_tracked_centre_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_tracked_velocity_ = Eigen::Vector3d::Zero();
  bool has_tracked_velocity_ = false;
  std::optional<double> last_tracked_time_;
  int relocalizations_ = 0;
  std::vector<KeyframeId> local_keyframes_;
  std::vector<MapPointId> local_points_;
  std::vector<FrameRecord> records_;
};

}  // namespace coloc::slam::tracking
