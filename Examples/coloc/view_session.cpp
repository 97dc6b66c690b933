#include "Examples/coloc/view_session.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "Examples/coloc/cli_common.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::cli {

namespace fs = std::filesystem;

void add_live_view_options(CLI::App& verb, ViewArgs& args) {
  verb.add_flag("--view", args.enabled,
                "Serve a live view of the run in the browser (http://127.0.0.1:8080/)");
  verb.add_option("--view-port", args.port, "Viewer port (0: any free port)")
      ->check(CLI::Range(0, 65535));
  verb.add_option("--view-bind", args.bind, "Viewer address (127.0.0.1: this machine only)");
  verb.add_option("--view-fps", args.max_fps, "Live frames pushed to the page per second")
      ->check(CLI::Range(0.1, 100.0));
  verb.add_option("--view-wait", args.wait_s,
                  "Wait up to this many seconds for a page to connect before the first frame");
  verb.add_option("--view-linger", args.linger_s,
                  "Keep serving the final map this many seconds after the run (-1: until Ctrl-C)");
}

std::unique_ptr<slam::view::ViewServer> start_view_server(const ViewArgs& args,
                                                          const fs::path& report, bool required) {
  slam::view::ViewServerOptions options;
  options.bind = args.bind;
  options.port = args.port;
  options.web_root = args.web_root.empty() ? data_dir() / "web" : args.web_root;
  options.report_dir = report;
  try {
    auto server = std::make_unique<slam::view::ViewServer>(options);
    spdlog::info("viewer at {} (Ctrl-C to stop)", server->url());
    return server;
  } catch (const Error& e) {
    if (required) throw;
    spdlog::warn("viewer not started, the run goes on without it: {}", e.what());
    return nullptr;
  }
}

KeyframeImages::KeyframeImages(const fs::path& sequence)
    : sequence_(dataset::open_sequence(sequence)) {
  for (std::size_t i = 0; i < sequence_->size(); ++i)
    index_.emplace(sequence_->timestamp(i), i);
}

std::optional<std::string> KeyframeImages::jpeg(double timestamp) const {
  auto it = index_.lower_bound(timestamp - 1e-3);
  if (it == index_.end() || std::abs(it->first - timestamp) > 1e-3) return std::nullopt;
  try {
    const dataset::Frame f = sequence_->frame(it->second);
    std::vector<std::uint8_t> bytes;
    cv::imencode(".jpg", f.color, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
    return std::string(bytes.begin(), bytes.end());
  } catch (const Error& e) {
    spdlog::warn("keyframe image: {}", e.what());
    return std::nullopt;
  }
}

void wait_for_page(const slam::view::ViewServer& server, double seconds) {
  if (seconds <= 0.0) return;
  spdlog::info("waiting up to {} s for a page at {}", seconds, server.url());
  if (!server.wait_for_client(seconds))
    spdlog::warn("no page after {} s: starting anyway", seconds);
}

}  // namespace coloc::cli

namespace coloc::cli {

bool TimedObserver::wants_frame(double timestamp) {
  start_ = std::chrono::steady_clock::now();
  start_cpu_s_ = thread_cpu_seconds();
  const bool wanted = inner_.wants_frame(timestamp);
  if (!wanted) add();
  return wanted;
}

void TimedObserver::on_frame(slam::system::FrameSnapshot snapshot) {
  inner_.on_frame(std::move(snapshot));
  ++stats_.taken;
  add();
}

void TimedObserver::add() {
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  const double cpu_ms = 1e3 * (thread_cpu_seconds() - start_cpu_s_);
  ++stats_.frames;
  stats_.total_ms += ms;
  stats_.max_ms = std::max(stats_.max_ms, ms);
  stats_.cpu_total_ms += cpu_ms;
  stats_.cpu_max_ms = std::max(stats_.cpu_max_ms, cpu_ms);
}

LiveSystemView::LiveSystemView(slam::view::ViewServer& server, const ViewArgs& args,
                               const fs::path& sequence)
    : server_(server), args_(args) {
  if (!sequence.empty()) images_ = std::make_shared<KeyframeImages>(sequence);
  server_.set_info(
      Json{{"mode", "live mapping"}, {"map", sequence.filename().string()}, {"live", true}}.dump());
}

LiveSystemView::~LiveSystemView() {
  detach();
}

void LiveSystemView::serve_images(
    const std::function<std::optional<double>(std::uint64_t)>& timestamp_of) {
  if (!images_) return;
  server_.set_keyframe_image_source(
      [images = images_, timestamp_of](std::uint64_t id) -> std::optional<std::string> {
        const auto t = timestamp_of(id);
        return t ? images->jpeg(*t) : std::nullopt;
      });
}

void LiveSystemView::attach(slam::system::System& system) {
  system_ = &system;
  slam::view::LiveFeedOptions options;
  options.max_fps = args_.max_fps;
  // Residuals are left out: they would hold the map lock, which tracking needs, too long.
  feed_ = std::make_unique<slam::view::LiveFeed>(server_, options, [&system] {
    return system.with_map(
        [](const slam::map::Map& m) { return slam::view::scene_of(m, {.residuals = false}); });
  });
  timed_ = std::make_unique<TimedObserver>(*feed_);
  system.set_observer(timed_.get());
  server_.set_keyframe_source([&system](std::uint64_t id) {
    return system.with_map(
        [id](const slam::map::Map& m) { return slam::view::keyframe_json(m, id); });
  });
  serve_images([&system](std::uint64_t id) {
    return system.with_map([id](const slam::map::Map& m) -> std::optional<double> {
      const auto* kf = m.keyframe(KeyframeId(id));
      return kf ? std::optional(kf->frame.timestamp) : std::nullopt;
    });
  });
  wait_for_page(server_, args_.wait_s);
}

void LiveSystemView::finish(const slam::system::System& system) {
  // The run is over: no more frames, and the feed's snapshots would replace the final scene.
  if (system_ != nullptr) system_->set_observer(nullptr);
  if (feed_) {
    feed_->stop();
    stats_ = feed_->stats();
  }
  final_map_ = system.with_map(
      [](const slam::map::Map& m) { return std::make_shared<const slam::map::Map>(m); });
  const slam::view::MapScene scene = slam::view::scene_of(*final_map_);
  // Past any version the feed has used.
  const std::uint64_t version = 1u << 30;
  server_.set_scene(slam::view::scene_json(scene, version), version);
}

void LiveSystemView::detach() {
  if (system_ == nullptr) return;
  system_->set_observer(nullptr);
  feed_->stop();
  if (!final_map_) stats_ = feed_->stats();
  // The panels read the final map from now on (or nothing, when the run failed before it).
  std::shared_ptr<const slam::map::Map> map = final_map_;
  server_.set_keyframe_source([map](std::uint64_t id) -> std::optional<std::string> {
    return map ? slam::view::keyframe_json(*map, id) : std::nullopt;
  });
  serve_images([map](std::uint64_t id) -> std::optional<double> {
    const auto* kf = map ? map->keyframe(KeyframeId(id)) : nullptr;
    return kf ? std::optional(kf->frame.timestamp) : std::nullopt;
  });
  system_ = nullptr;
}

slam::view::LiveFeedStats LiveSystemView::stats() const {
  return feed_ && system_ && !final_map_ ? feed_->stats() : stats_;
}

}  // namespace coloc::cli

namespace coloc::cli {

void linger(const slam::view::ViewServer& server, const slam::view::LiveFeedStats& f,
            double seconds) {
  const slam::view::ViewServerStats s = server.stats();
  spdlog::info(
      "viewer: {} frames offered, {} published, {} map snapshots (longest {:.2f} ms under the map "
      "lock), {} pages ({} gone), {} events dropped for slow pages",
      f.frames_offered, f.frames_published, f.map_snapshots, f.max_map_copy_ms, s.clients_connected,
      s.disconnected, s.events_dropped);
  if (seconds == 0.0) return;
  spdlog::info(
      "serving the final map at {} {}", server.url(),
      seconds < 0.0 ? std::string("until Ctrl-C") : "for " + std::to_string(seconds) + " s");
  wait_for_stop_signal(seconds);
}

}  // namespace coloc::cli

namespace coloc::cli {

LiveLocalizationView::LiveLocalizationView(slam::view::ViewServer& server, const ViewArgs& args,
                                           const slam::map::Map& map, std::mutex& mutex,
                                           const std::string& frame, const fs::path& sequence) {
  slam::view::MapScene scene;
  {
    std::lock_guard lock(mutex);
    scene = slam::view::scene_of(map);
  }
  scene.frame = frame;
  server.set_info(Json{
      {"mode", "live localization"},
      {"map", sequence.filename().string()},
      {"live", true}}.dump());
  server.set_scene(slam::view::scene_json(scene, 1), 1);
  server.set_keyframe_source([&map, &mutex](std::uint64_t id) {
    std::lock_guard lock(mutex);
    return slam::view::keyframe_json(map, id);
  });
  if (!sequence.empty()) {
    images_ = std::make_shared<KeyframeImages>(sequence);
    server.set_keyframe_image_source(
        [images = images_, &map, &mutex](std::uint64_t id) -> std::optional<std::string> {
          std::optional<double> t;
          {
            std::lock_guard lock(mutex);
            if (const auto* kf = map.keyframe(KeyframeId(id))) t = kf->frame.timestamp;
          }
          return t ? images->jpeg(*t) : std::nullopt;
        });
  }
  slam::view::LiveFeedOptions options;
  options.max_fps = args.max_fps;
  feed_ = std::make_unique<slam::view::LiveFeed>(server, options);
  wait_for_page(server, args.wait_s);
}

void LiveLocalizationView::offer(const cv::Mat& image, bool rgb, std::uint64_t index,
                                 double timestamp, slam::system::ObservedState state,
                                 const SE3& world_from_cam, int inliers, double ms,
                                 const slam::frame::Frame* frame) {
  if (!feed_ || !feed_->wants_frame(timestamp)) return;
  slam::system::FrameSnapshot s;
  s.index = index;
  s.timestamp = timestamp;
  s.state = state;
  s.world_from_cam = world_from_cam;
  s.inliers = inliers;
  s.track_ms = ms;
  if (state != slam::system::ObservedState::kLost && frame != nullptr)
    slam::system::fill_keypoints(*frame, s);
  s.image = image.clone();
  s.rgb = rgb;
  feed_->on_frame(std::move(s));
}

void LiveLocalizationView::finish() {
  if (!feed_) return;
  feed_->stop();
  stats_ = feed_->stats();
  feed_.reset();
}

slam::view::LiveFeedStats LiveLocalizationView::stats() const {
  return feed_ ? feed_->stats() : stats_;
}

}  // namespace coloc::cli
