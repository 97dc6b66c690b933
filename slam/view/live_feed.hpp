#pragma once
// Live viewing of a running SLAM or localization session: a FrameObserver (slam/system) that
// takes at most `max_fps` frames per second, and only while a page is open, into a one-slot
// mailbox (a frame arriving while the previous one is still being encoded is not taken), and a
// thread of its own that encodes the image (JPEG), publishes the frame's state, pose and
// keypoints as a `frame` event, and refreshes the map scene every so often.
//
// The tracking thread's cost: when no page is open, one atomic load per frame; otherwise, per
// frame taken, a copy of the image and keypoints (wants_frame/on_frame never wait on the
// viewer). The map snapshot (MapSnapshotFn) runs on the feed's thread but takes the map's lock,
// which tracking also takes: it is spaced so that at most `map_lock_share` of the wall time is
// spent in it (measured: `coloc bench view`).
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

#include "slam/system/frame_observer.hpp"
#include "slam/view/scene.hpp"
#include "slam/view/server.hpp"

namespace coloc::slam::view {

struct LiveFeedOptions {
  double max_fps = 10.0;         // frames pushed to the pages per second
  double map_interval_s = 1.0;   // least time between two map snapshots
  double map_lock_share = 0.02;  // most of the wall time spent copying the map
  int jpeg_quality = 70;         // 1..100
  int max_image_width = 640;     // wider frames are scaled down before encoding
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct LiveFeedStats {
  std::uint64_t frames_offered = 0;  // wants_frame() calls
  std::uint64_t frames_taken = 0;    // snapshots taken by on_frame()
  std::uint64_t frames_published = 0;
  std::uint64_t map_snapshots = 0;
  // Longest MapSnapshotFn call: the wait for the map lock and the copy under it.
  double max_map_copy_ms = 0.0;
  double max_encode_ms = 0.0;  // longest JPEG encoding of a frame
};

// Builds the scene of the running map (takes the map's lock itself); called on the feed's thread.
using MapSnapshotFn = std::function<MapScene()>;

class LiveFeed : public system::FrameObserver {
 public:
  // `server` must outlive the feed. Without `map`, the scene is the caller's (set_scene).
  LiveFeed(ViewServer& server, LiveFeedOptions options, MapSnapshotFn map = {});
  ~LiveFeed() override;
  LiveFeed(const LiveFeed&) = delete;
  LiveFeed& operator=(const LiveFeed&) = delete;

  bool wants_frame(double timestamp) override;
  void on_frame(system::FrameSnapshot snapshot) override;
  // Takes a map snapshot now (e.g. when the run has finished and the final map is in place).
  void refresh_map();
  LiveFeedStats stats() const;
  // Stops the feed's thread (idempotent; the destructor calls it).
  void stop();

 private:
  void run();
  void publish_frame(const system::FrameSnapshot& s);
  void snapshot_map();

  ViewServer& server_;
  LiveFeedOptions options_;
  MapSnapshotFn map_;
  std::atomic<std::size_t> pages_{0};  // open event streams, as the feed's thread last saw
  std::atomic<bool> busy_{false};      // the mailbox holds a frame not yet published
  std::atomic<std::uint64_t> offered_{0};
  std::chrono::steady_clock::time_point last_taken_{};  // tracking thread only

  mutable std::mutex mutex_;  // mailbox_, stop_, refresh_, stats_
  std::condition_variable wake_;
  std::optional<system::FrameSnapshot> mailbox_;
  bool stop_ = false;
  bool refresh_ = false;
  LiveFeedStats stats_;
  std::uint64_t map_version_ = 0;  // feed thread only
  std::thread thread_;
};

}  // namespace coloc::slam::view
