#pragma once
// The RGB-D SLAM system: tracking in the caller's thread, local mapping in one std::thread,
// joined by the mapper's bounded blocking queue (the mapper is the tracker's keyframe sink),
// loop closing in another behind the mapper (its output sink; options.loop.enabled); the map
// shared under SharedMap::mutex. `tracking.wait_for_sink` makes it sequential.
// Construct, call track() per frame, then shutdown() (also done by the destructor) and read
// the trajectory. Not copyable; track() must be called from one thread at a time.
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/timing.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/loop/loop_closer.hpp"
#include "slam/map/shared_map.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapping/global_ba.hpp"
#include "slam/mapping/local_mapper.hpp"
#include "slam/settings/settings.hpp"
#include "slam/system/frame_observer.hpp"
#include "slam/tracking/tracker.hpp"
#include "slam/tuning/system_options.hpp"

namespace coloc::markers {
class MarkerDetector;
}

namespace coloc::slam::system {

// Tracking's keyframe decisions over a run, in frames.
struct KeyframeDecisions {
  std::size_t made = 0;          // keyframes made (the map keeps those not culled)
  std::size_t deferred = 0;      // a keyframe was needed but put off (a weak or off-course frame)
  std::size_t refused_busy = 0;  // ... refused: three keyframes were queued for the mapper
};

struct SystemSummary {
  std::size_t frames = 0, tracked = 0, lost = 0;
  std::size_t keyframes = 0, points = 0;
  int relocalizations = 0;
  // Seconds: the rolling-shutter readout local mapping estimated (settings without
  // Camera.readoutTime); empty when the settings give it.
  std::optional<double> estimated_readout;
  mapping::MappingStats mapping;
  loop::LoopStats loop;  // empty when loop closing is off
  // Per frame: extraction (on the tracking thread, or ahead on one of its own for
  // `extracted_ahead` frames), the rest of tracking, and both.
  SampleStats extract_ms, track_ms, total_ms;
  std::size_t extracted_ahead = 0;
  SampleStats pose_ms, local_map_ms, keyframe_ms;  // stages of track_ms
  KeyframeDecisions keyframe_decisions;
  std::string describe() const;
};

class System {
 public:
  // Needs settings with depth (Camera.bf, ThDepth). Without Camera.width/height the first
  // image gives the size; later images of another size are rejected (coloc::Error naming
  // Camera.width). The settings' Coloc.* keys override `options` (slam/tuning/tuning.hpp) and
  // Camera.RGB sets tracking.rgb_input. `vocabulary` must outlive the System.
  System(const settings::Settings& settings, const bow::Vocabulary& vocabulary,
         SystemOptions options = {});
  // Continues a saved map (mapdb::load_map with the same vocabulary): the first frames
  // relocalize into it, then tracking and mapping extend it (one frame of reference, loops
  // closed across recordings). Until a frame relocalizes, nothing is added to the map. The
  // map's metadata (its frame name and registration) carries over to save_map().
  System(const settings::Settings& settings, const bow::Vocabulary& vocabulary,
         SystemOptions options, mapdb::LoadedMap loaded);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // `image` 8-bit grey, or colour in the settings' Camera.RGB order; `depth` CV_32FC1 metres
  // (0 = invalid); timestamp in seconds.
  tracking::TrackingResult track(const cv::Mat& image, const cv::Mat& depth, double timestamp);
  // The same with the image's features extracted beforehand by a feature_extraction() (on
  // another thread: slam/pipeline/extract_ahead.hpp); the map is the same either way.
  tracking::TrackingResult track(const cv::Mat& image, const cv::Mat& depth, double timestamp,
                                 tracking::ImageFeatures extracted);
  // The extraction track() runs (the settings' ORB options, camera and colour order), for
  // another thread; one per thread.
  tracking::FeatureExtraction feature_extraction() const;
  // Stops local mapping (aborting a running BA) and joins its thread, then loop closing
  // (aborting a global BA running in the background). Idempotent.
  void shutdown();
  // Global bundle adjustment of the finished map (shuts local mapping down first). For offline
  // mapping: the trajectory and the map then reflect all observations at once.
  // `imu`: this recording's IMU measurements, which tie the tilt of the keyframes this System
  // made to gravity and their relative rotations to the gyro, or none. A continued map's loaded
  // keyframes are of another recording and clock: vision alone holds them.
  mapping::GlobalBaReport optimize_map(const mapping::GlobalBaOptions& options = {},
                                       const mapping::InertialMeasurements& imu = {});

  // Saves the map (slam/mapdb). While mapping runs, a live save (tracking is held up only for
  // short copies; the file is the map as of one moment); after shutdown(), the finished map.
  // The metadata carries the vocabulary checksum, the settings file's text, the camera, and
  // the frame of a continued map. Throws coloc::Error naming the file; the previous file is
  // then intact.
  mapdb::SaveReport save_map(const std::filesystem::path& path,
                             const mapdb::SaveOptions& options = {}) const;

  // world_from_cam of every tracked frame (after initialization), following keyframe updates.
  Trajectory trajectory() const;
  Trajectory keyframe_trajectory() const;
  SystemSummary summary() const;
  // A viewer's window onto tracking (null: none). Borrowed: it must outlive the System or be
  // reset to null first. Set it before the first frame, from the tracking thread.
  void set_observer(FrameObserver* observer) { observer_ = observer; }
  // Runs f(const map::Map&) under the map lock.
  template <typename F>
  auto with_map(F&& f) const {
    std::lock_guard lock(shared_->mutex);
    return f(static_cast<const map::Map&>(shared_->map));
  }

 private:
  // Builds the frame geometry and the tracker for images of this size.
  void start_tracking(int width, int height);
  // Starts tracking at the first image and checks the image against the settings' size.
  void check_image(const cv::Mat& image, const cv::Mat& depth);
  // Keeps the frame's timings and keyframe decision, and shows the observer the frame.
  void account(const cv::Mat& image, const tracking::TrackingResult& r, double timestamp);

  mapdb::MapMetadata metadata() const;
  // Hands the observer this frame's snapshot (tracking thread).
  void notify(const cv::Mat& image, const tracking::TrackingResult& r, double timestamp);

  SystemOptions options_;
  settings::Settings settings_;  // Camera width/height filled in by start_tracking()
  const bow::Vocabulary& vocabulary_;
  features::ExtractorOptions extractor_;
  std::unique_ptr<map::SharedMap> shared_;
  std::unique_ptr<markers::MarkerDetector> detector_;
  std::unique_ptr<loop::LoopCloser> loop_closer_;  // before mapper_: the mapper pushes into it
  std::unique_ptr<mapping::LocalMapper> mapper_;
  std::unique_ptr<tracking::Tracker> tracker_;
  // The continued map's frame and registration (save_map keeps them); "slam" otherwise.
  std::string frame_name_ = "slam";
  // The first keyframe this System made: a continued map's loaded ones come before it.
  KeyframeId first_keyframe_{0};
  std::optional<Sim3> frame_from_slam_;
  bool running_ = true;  // mapping threads not yet shut down
  FrameObserver* observer_ = nullptr;
  std::vector<double> extract_ms_, track_ms_, pose_ms_, local_map_ms_, keyframe_ms_;
  KeyframeDecisions decisions_;
  std::size_t extracted_ahead_ = 0;  // frames tracked with features extracted beforehand
};

// A new System, or (with `load_map`) one continuing that saved map; progress of the load on
// `progress` (optional). Throws coloc::Error naming the file when the map does not load.
std::unique_ptr<System> open_system(const settings::Settings& settings,
                                    const bow::Vocabulary& vocabulary, SystemOptions options,
                                    const std::filesystem::path& load_map,
                                    const mapdb::ProgressFn& progress = {});

}  // namespace coloc::slam::system
