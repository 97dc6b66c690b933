#pragma once
// What `coloc view`, `coloc map --view` and `coloc localize --view` share: the viewer's command
// line options, the server started from them, keyframe images read from the mapped sequence,
// and waiting (for a page, for Ctrl-C) without polling.
#include <CLI/CLI.hpp>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "Examples/coloc/stop_signals.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/map/map.hpp"
#include "slam/system/system.hpp"
#include "slam/view/live_feed.hpp"
#include "slam/view/server.hpp"

namespace coloc::cli {

struct ViewArgs {
  bool enabled = false;  // --view (map, localize); always on for `coloc view`
  int port = 8080;
  std::string bind = "127.0.0.1";
  std::filesystem::path web_root;  // empty: the page built with this binary
  double max_fps = 10.0;           // live frames pushed per second
  double wait_s = 0.0;             // map/localize: wait this long for a page before the first frame
  double linger_s = 0.0;  // map/localize: keep serving the final map this long (-1: Ctrl-C)
};

// --view, --view-port, --view-bind, --view-fps, --view-wait, --view-linger (map, localize).
void add_live_view_options(CLI::App& verb, ViewArgs& args);

// The server, or (live verbs) nullptr with a warning when it cannot start: a busy port must
// not cost a mapping run. `required` (coloc view): the error is thrown instead.
std::unique_ptr<slam::view::ViewServer> start_view_server(const ViewArgs& args,
                                                          const std::filesystem::path& report,
                                                          bool required);

// Colour images of a recorded sequence by timestamp (within 1 ms), as JPEG for the keyframe
// panel. Thread-safe (reads from disk per call).
class KeyframeImages {
 public:
  explicit KeyframeImages(const std::filesystem::path& sequence);
  std::optional<std::string> jpeg(double timestamp) const;

 private:
  std::unique_ptr<dataset::Sequence> sequence_;
  std::map<double, std::size_t> index_;  // timestamp -> frame
};

// What the tracking thread spends in the viewer's hook: wants_frame() for every frame and, for
// the frames taken, the snapshot (image copy, keypoints) up to on_frame()'s return.
struct HookStats {
  std::uint64_t frames = 0, taken = 0;
  double total_ms = 0.0, max_ms = 0.0;          // wall time (includes being preempted)
  double cpu_total_ms = 0.0, cpu_max_ms = 0.0;  // the tracking thread's CPU time
};

// Wraps an observer and times it (in the tracking thread; read the stats after the run).
class TimedObserver : public slam::system::FrameObserver {
 public:
  explicit TimedObserver(slam::system::FrameObserver& inner) : inner_(inner) {}
  bool wants_frame(double timestamp) override;
  void on_frame(slam::system::FrameSnapshot snapshot) override;
  const HookStats& stats() const { return stats_; }

 private:
  void add();
  slam::system::FrameObserver& inner_;
  std::chrono::steady_clock::time_point start_;
  double start_cpu_s_ = 0.0;
  HookStats stats_;
};

// A live view of a running System (`coloc map --view`, `coloc bench view`): attach() before the
// first frame (the feed observes tracking; keyframe panels read the running map under its
// lock), finish() once the map is final (the last scene, and a copy of the map the panels read
// from then on), detach() before the System goes.
class LiveSystemView {
 public:
  // `sequence` (may be empty): keyframe images. `server` must outlive this object.
  LiveSystemView(slam::view::ViewServer& server, const ViewArgs& args,
                 const std::filesystem::path& sequence);
  ~LiveSystemView();
  void attach(slam::system::System& system);
  void finish(const slam::system::System& system);
  void detach();
  slam::view::LiveFeedStats stats() const;
  const HookStats& hook() const { return timed_->stats(); }

 private:
  void serve_images(const std::function<std::optional<double>(std::uint64_t)>& timestamp_of);

  slam::view::ViewServer& server_;
  ViewArgs args_;
  std::shared_ptr<KeyframeImages> images_;
  std::unique_ptr<slam::view::LiveFeed> feed_;
  std::unique_ptr<TimedObserver> timed_;
  slam::system::System* system_ = nullptr;
  std::shared_ptr<const slam::map::Map> final_map_;
  slam::view::LiveFeedStats stats_;  // of the feed, kept after detach()
};

// After a live run: logs what the viewer did, then keeps serving the final map `seconds` (< 0:
// until Ctrl-C).
void linger(const slam::view::ViewServer& server, const slam::view::LiveFeedStats& feed,
            double seconds);

// Waits until a page is connected or `seconds` passed (logs what it waits for).
void wait_for_page(const slam::view::ViewServer& server, double seconds);

}  // namespace coloc::cli

namespace coloc::cli {

// A live view of a localization session (`coloc localize --view`): the fixed map served once
// (scene and keyframe panels read it under its mutex, which localizers share), each localized
// frame offered to the feed.
class LiveLocalizationView {
 public:
  // `map` and `mutex` must outlive this object; `sequence` (may be empty): keyframe images.
  LiveLocalizationView(slam::view::ViewServer& server, const ViewArgs& args,
                       const slam::map::Map& map, std::mutex& mutex, const std::string& frame,
                       const std::filesystem::path& sequence);
  // After each frame (the localizer's thread): a snapshot when the feed wants one.
  void offer(const cv::Mat& image, bool rgb, std::uint64_t index, double timestamp,
             slam::system::ObservedState state, const SE3& world_from_cam, int inliers, double ms,
             const slam::frame::Frame* frame);
  // Stops the feed (the linger serves the map only).
  void finish();
  slam::view::LiveFeedStats stats() const;

 private:
  std::shared_ptr<KeyframeImages> images_;
  std::unique_ptr<slam::view::LiveFeed> feed_;
  slam::view::LiveFeedStats stats_;
};

}  // namespace coloc::cli
