#pragma once
// Local mapping (ORB-SLAM's LocalMapping) in its own thread, fed by a bounded blocking queue of
// keyframe ids that tracking has already inserted into the map. Per keyframe: BoW vector and
// database entry, marker detection, point descriptors/normals and covisibility update,
// recent-point culling, duplicate fusion with the neighbours, local bundle adjustment (Ceres,
// keyframes outside the window fixed) and redundant-keyframe culling.
//
// Threads: push()/idle()/interrupt_ba()/stop() are called from the tracking thread; everything
// else runs in the mapper's thread. The map is touched only under SharedMap::mutex; BA runs on
// a copy without the lock, and is abandoned between iterations when interrupt_ba() or stop()
// raises the abort flag (a new keyframe is more useful than a finished BA).
#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <thread>
#include <vector>

#include "markers/detector.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/map/shared_map.hpp"
#include "slam/mapping/bounded_queue.hpp"
#include "slam/optim/bundle_adjustment.hpp"

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
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct KeyframeMessage {
  KeyframeId id;
  cv::Mat grey;  // the keyframe's image, for marker detection (may be empty)
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
};

class LocalMapper {
 public:
  // `map`, `vocabulary` and `detector` (may be null: no markers) must outlive the mapper;
  // `marker_size` (metres) is stored with each keyframe's marker observations.
  LocalMapper(map::SharedMap& map, const bow::Vocabulary& vocabulary,
              const markers::MarkerDetector* detector, double marker_size,
              LocalMappingOptions options);
  ~LocalMapper();  // stop()
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  void start();
  // Blocks while the queue is full; false after stop().
  bool push(KeyframeMessage message);
  // No keyframe queued or being processed.
  bool idle() const;
  std::size_t queued() const { return queue_.size(); }
  // Blocks until idle (the sequential mode of tests and benchmarks).
  void wait_idle();
  // Asks a running bundle adjustment to stop at its next iteration.
  void interrupt_ba() { abort_ba_ = true; }
  // Closes the queue, aborts BA, processes what is queued without BA, joins. Idempotent.
  void stop();
  MappingStats stats() const;

 private:
  void run();
  void process(const KeyframeMessage& message);
  void insert_keyframe(const KeyframeMessage& message);
  void cull_recent_points(KeyframeId current);
  void fuse_neighbours(KeyframeId current);
  void local_bundle_adjustment(KeyframeId current);
  void cull_keyframes(KeyframeId current);

  map::SharedMap& shared_;
  const bow::Vocabulary& vocabulary_;
  const markers::MarkerDetector* detector_;
  double marker_size_;
  LocalMappingOptions options_;
  BoundedQueue<KeyframeMessage> queue_;
  std::thread thread_;
  std::atomic<bool> abort_ba_{false};
  std::atomic<bool> stopping_{false};
  mutable std::mutex state_mutex_;  // guards pending_ and stats_
  std::condition_variable idle_cv_;
  int pending_ = 0;  // pushed but not yet processed
  MappingStats stats_;
  std::vector<MapPointId> recent_points_;  // mapper thread only
};

}  // namespace coloc::slam::mapping
