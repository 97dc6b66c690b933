#pragma once
// Loop closing (ORB-SLAM's LoopClosing) in its own thread, fed by a bounded blocking queue of
// the keyframes local mapping has finished (the closer is the mapper's output map::KeyframeSink).
// Per keyframe: candidates and the consistency test (detection.hpp), geometric verification
// with the aliasing test (verification.hpp); for an accepted loop, local mapping is paused and
// the map corrected under the map lock (correction.hpp), then a global BA of the whole map runs
// in a background thread. A new loop or stop() aborts that BA; a finished one is merged: what
// it optimized takes its result, keyframes and points added meanwhile move with their spanning-
// tree parent / reference keyframe. Every accepted or rejected loop is logged with its evidence.
//
// Threads: the KeyframeSink members, stats() and stop() are called from other threads; the
// detector, verification and corrections run in the closer's thread, the global BA in its own.
// Map edits hold SharedMap::mutex with local mapping paused (pauses nest, so the BA's merge and
// a correction never release each other's pause); a correction first aborts and joins the BA.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <random>
#include <thread>
#include <vector>

#include "slam/core/stage_queue.hpp"
#include "slam/loop/detection.hpp"
#include "slam/loop/loop_options.hpp"
#include "slam/loop/verification.hpp"
#include "slam/map/keyframe_sink.hpp"
#include "slam/map/shared_map.hpp"
#include "slam/mapping/local_mapper.hpp"

namespace coloc::slam::loop {

struct LoopRecord {
  KeyframeId current, candidate;
  double current_time = 0.0, candidate_time = 0.0;  // the two keyframes' frame timestamps
  SE3 candidate_from_current;                       // as verified (what the loop asserts)
  double score = 0.0;
  int consistency = 0, bow_matches = 0, ransac_inliers = 0, inliers = 0;
  int current_pose_inliers = 0;     // LoopVerification::current_pose_inliers
  double hypothesis_moved_m = 0.0;  // LoopVerification::hypothesis_moved_m
  double path_m = 0.0, correction_m = 0.0, correction_rad = 0.0;
  FreeSpaceCount free_space;
  int fused = 0;
  double ms = 0.0;  // correction wall time (map locked, mapping paused)
};

struct LoopStats {
  int keyframes = 0;            // keyframes examined
  int candidates = 0;           // consistent candidates verified
  int rejected = 0;             // of those, rejected by verification
  int rejected_aliasing = 0;    // of those, by the plausibility (aliasing) test
  int rejected_look_alike = 0;  // of those, by the free-space test
  // Candidates whose verified pose the current-pose hypothesis moved by more than
  // LoopOptions::max_drift_m: a repeating texture's other period, caught.
  int shifted_by_current_pose = 0;
  std::vector<LoopRecord> loops;
  int global_ba_runs = 0, global_ba_aborted = 0;
  std::vector<double> global_ba_ms;
};

class LoopCloser final : public map::KeyframeSink {
 public:
  // `map` must outlive the closer. `depth_camera`: the camera of the keyframes' stored depth,
  // for the free-space test (none: the test is not run).
  LoopCloser(map::SharedMap& map, LoopOptions options,
             std::optional<Camera> depth_camera = std::nullopt);
  ~LoopCloser() override;  // stop()
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  // `mapper` (may be null: nothing to pause, e.g. in tests) must outlive the closer.
  void start(mapping::LocalMapper* mapper);
  // map::KeyframeSink. push() blocks while the queue is full and is false after stop().
  bool push(map::KeyframeMessage message) override;
  bool idle() const override;
  std::size_t queued() const override { return queue_.size(); }
  bool accepting() const override { return true; }
  void interrupt() override {}  // detection is short; a correction must not be cut
  void wait_idle() override;
  // Closes the queue, examines what is queued, aborts a running global BA, joins. Idempotent.
  void stop();
  LoopStats stats() const;
  bool global_ba_running() const { return ba_running_; }
  // Blocks until a running global BA has finished (merged or aborted).
  void wait_global_ba();

 private:
  void run();
  void process(KeyframeId current);
  // Verifies the consistent candidates, best first; corrects with the first accepted.
  bool try_close(KeyframeId current, const Detection& detection);
  void correct(const LoopVerification& loop, const LoopCandidate& candidate);
  // Pauses local mapping and stops the global BA without deadlock: the mapper may be blocked
  // pushing into our full queue (and the BA's merge waiting for the mapper), so the queue is
  // drained into backlog_ between the pause request and the waits.
  void pause_for_correction();
  void start_global_ba();
  void global_ba();

  map::SharedMap& shared_;
  LoopOptions options_;
  std::optional<Camera> depth_camera_;
  mapping::LocalMapper* mapper_ = nullptr;
  StageQueue<map::KeyframeMessage> queue_;
  std::deque<KeyframeId> backlog_;  // closer thread only (drained from queue_ while pausing)
  std::thread thread_, ba_thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> abort_ba_{false};
  std::atomic<bool> ba_running_{false};
  mutable std::mutex state_mutex_;  // guards stats_
  LoopStats stats_;
  LoopDetector detector_;    // closer thread only
  std::mt19937 rng_{12345};  // closer thread only (RANSAC; fixed seed: reproducible runs)
  std::size_t last_loop_kf_count_ = 0;  // keyframes examined at the last correction
};

}  // namespace coloc::slam::loop
