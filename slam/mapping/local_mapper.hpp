#pragma once
// Local mapping (ORB-SLAM's LocalMapping) in its own thread, fed by a bounded blocking queue of
// keyframe ids that tracking has already inserted into the map (the mapper is tracking's
// map::KeyframeSink). Per keyframe: BoW vector and database entry, marker detection, point
// descriptors/normals and covisibility update, recent-point culling, new points by
// triangulation, duplicate fusion with the neighbours, local bundle adjustment (Ceres, keyframes
// outside the window fixed; with an unknown rolling-shutter readout, the readout too) and
// redundant-keyframe culling. Each processed keyframe is then handed to the mapper's own output
// sink (a loop closer), when there is one.
//
// Threads: the KeyframeSink members, pause()/resume() and stop() are called from other threads;
// everything else runs in the mapper's thread. The map is touched only under SharedMap::mutex; BA
// runs on a copy without the lock, and is abandoned between iterations when interrupt(), pause()
// or stop() raises the abort flag (a new keyframe or a loop correction matters more).
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/stage_queue.hpp"
#include "slam/map/keyframe_sink.hpp"
#include "slam/map/shared_map.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::markers {
class MarkerDetector;
}

namespace coloc::slam::mapping {

struct LocalMappingOptions {
  std::size_t queue_capacity = 4;      // keyframes waiting for the mapper
  std::size_t fusion_neighbours = 10;  // covisible keyframes searched for duplicates
  double fusion_radius = 3.0;          // pixels at level 0
  bool triangulation = true;           // new points from matches with covisible keyframes
  bool local_ba = true;
  optim::BundleOptions ba;
  bool keyframe_culling = true;
  double redundancy = 0.9;  // a keyframe whose points are this often seen by 3 others is culled
  // ... and at this share when its neighbours before and after look within `straight_turn_deg`
  // of its direction. Walking, each keyframe holds many points seen by one or two others only,
  // so ORB-SLAM's 90 % never culls (twin building: the most redundant had 64 %), while its
  // neighbours see what it sees. 0.2 brings the twin to 1.3x ORB-SLAM2's keyframes (230 -> 204)
  // and keeps 7-Scenes' error 3 mm lower with half the keyframes; fr1/rpy turns more than 5
  // degrees between keyframes and is left alone. It costs the poses as tracked a little (twin
  // seed 2 10.2 -> 12.7 mm before the loop closes; the culling test's hovering camera 3.9 ->
  // 4.1 mm). It was off until the localizer stopped accepting look-alike relocalizations: one
  // demo room map lost its second walk to one. docs/results/mapping-speed.md has the sittings.
  double redundancy_straight = 0.2;
  double straight_turn_deg = 5.0;
  // Rolling-shutter readout unknown (SharedMap::estimate_readout): the local BA estimates it
  // with the poses, under a prior of `readout_step` seconds on its change (the window's data
  // outweigh it; it steadies windows without fast turns). The keyframes are compensated again
  // once it has moved `readout_publish` from what they use: small steps, as one large one
  // cost fr1/xyz 4.2 -> 5.7 mm.
  bool estimate_readout = true;
  double readout_step = 0.002;
  double readout_publish = 0.0001;
  double readout_max = 0.05;  // seconds: the estimate stays within [0, readout_max]
  // Where the estimate starts, as a share of the frame interval (Camera.fps): a rolling
  // shutter reads its rows over most of it, a global one over none, so half is the least wrong
  // guess either way, and the data move it within a few keyframes (a global shutter's to 0 ms in
  // 3 local BAs). From 0, the estimate was still near 5 ms when fr1/rpy turns fast at frame 50
  // (the Kinect's is 20-25 ms), and 5 of 40 paced runs with the ORB-SLAM3 file ended above
  // 25 mm (std 5.7 mm); from half, 1 of 40 (std 2.7 mm). The price: fr1/xyz 4.2 -> 4.5 mm, and
  // a global-shutter twin room without the key 3.7-4.0 -> 5.5 mm (its first second is
  // compensated for a shear it does not have). A map that is continued starts from its own.
  // Checked again once keyframes carried their poses' rate (and the first keyframe its pair's,
  // since limited to a known readout): from 0, fr1/xyz 4.3 -> 5.4 mm,
  // fr1/rpy and the keyless room level (8 and 2 interleaved runs). Half stays.
  double readout_start = 0.5;
  // Windows of fewer keyframes (the current one, its covisible ones and those held fixed at the
  // window's edge) leave the estimate as it is. It was added when the first local BAs of 2-4
  // keyframes took fr1/rpy's estimate (ORB-SLAM3 TUM1 file, paced) from 16.7 to 4 ms on every
  // run: 10 cut the runs above 19 mm from 11 of 47 to 0 of 35, but kept a global shutter
  // without the key at its start value longer (twin room 5.9 -> 10.4 mm). The cause was
  // keyframes whose rate was refined at the current readout (tracking::Tracker::
  // refine_rolling_shutter), which look right at any readout; since keyframes carry the rate of
  // their poses, the default has lost that tail (README, "Accuracy beside ORB-SLAM2"). Kept for
  // footage that turns fast from its first frame.
  std::size_t readout_min_keyframes = 0;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// One local BA: its window and where its time went (the figures its window and iteration
// budgets were set by; `coloc map` prints their medians and shares).
struct LocalBaRun {
  std::size_t free_poses = 0, fixed_poses = 0, points = 0, observations = 0;
  int iterations = 0;
  optim::BundleTiming timing;
};

struct MappingStats {
  int keyframes = 0;
  int ba_runs = 0;
  int ba_aborted = 0;
  int keyframes_culled = 0;
  int points_culled = 0;
  int points_fused = 0;
  int points_triangulated = 0;
  int markers = 0;            // marker observations stored in keyframes
  std::vector<double> ba_ms;  // wall time of each local BA
  std::vector<LocalBaRun> ba;
  // Wall time of each keyframe in the mapper, BA included: against the camera's frame period
  // times the frames between keyframes, whether a live mapper keeps up.
  std::vector<double> keyframe_ms;
};

class LocalMapper final : public map::KeyframeSink {
 public:
  // `map`, `vocabulary`, `detector` (may be null: no markers) and `output` (may be null: no
  // stage behind mapping) must outlive the mapper; `marker_size` (metres) is stored with each
  // keyframe's marker observations.
  LocalMapper(map::SharedMap& map, const bow::Vocabulary& vocabulary,
              const markers::MarkerDetector* detector, double marker_size,
              LocalMappingOptions options, map::KeyframeSink* output = nullptr);
  ~LocalMapper() override;  // stop()
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  void start();
  // map::KeyframeSink. push() blocks while the queue is full and is false after stop().
  bool push(map::KeyframeMessage message) override;
  bool idle() const override;
  std::size_t queued() const override { return queue_.size(); }
  bool accepting() const override { return !pause_requested_; }
  // Asks a running bundle adjustment to stop at its next iteration.
  void interrupt() override { abort_ba_ = true; }
  void wait_idle() override;

  // For a loop closer's correction: the mapper finishes (or abandons the BA of) the keyframe in
  // hand and then processes none until resume(); keyframes pushed meanwhile wait in the queue.
  // pause() returns once the mapper is paused, or stopped. Pauses nest: the mapper runs again
  // when every pause() (or request_pause()) has had its resume(). request_pause() asks without
  // waiting (a caller that must first unblock the mapper, e.g. by draining the queue the mapper
  // writes into, then calls wait_paused()).
  void pause();
  void request_pause();
  void wait_paused();
  void resume();
  bool paused() const;
  // Closes the queue, aborts BA, processes what is queued without BA, joins. Idempotent.
  void stop();
  MappingStats stats() const;

 private:
  void run();
  // Mapper thread, before processing a popped keyframe: waits while a pause is requested (not
  // when stopping), then marks the keyframe in hand.
  void take_in_hand();
  void process(const map::KeyframeMessage& message);
  void insert_keyframe(const map::KeyframeMessage& message);
  void cull_recent_points(KeyframeId current);
  void fuse_neighbours(KeyframeId current);
  void local_bundle_adjustment(KeyframeId current);
  // Under the map lock: the readout the last BA estimated (SharedMap::estimate_readout).
  void update_readout(double estimate);
  void cull_keyframes(KeyframeId current);

  map::SharedMap& shared_;
  const bow::Vocabulary& vocabulary_;
  const markers::MarkerDetector* detector_;
  double marker_size_;
  LocalMappingOptions options_;
  map::KeyframeSink* output_;
  // Seconds, mapper thread only: the last BA's readout, published in shared_.readout once it
  // moved far enough; starts from the published one (a continued map's).
  std::optional<double> readout_estimate_;
  StageQueue<map::KeyframeMessage> queue_;
  std::thread thread_;
  std::atomic<bool> abort_ba_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<bool> pause_requested_{false};
  mutable std::mutex state_mutex_;    // guards processing_, stats_; with state_cv_
  std::condition_variable state_cv_;  // processing_ changed, resume or stop
  int pause_requests_ = 0;            // pause()/request_pause() calls not yet resumed
  bool processing_ = false;           // the mapper thread has a keyframe in hand
  MappingStats stats_;
  std::vector<MapPointId> recent_points_;  // mapper thread only
};

}  // namespace coloc::slam::mapping
