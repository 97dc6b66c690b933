#include "slam/view/live_feed.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::slam::view {
namespace {

using Clock = std::chrono::steady_clock;

// BGR (or grey) JPEG of the frame, scaled down to `max_width`; the scale applied in `scale`.
std::string encode_jpeg(const cv::Mat& image, bool rgb, int quality, int max_width, double& scale) {
  cv::Mat bgr = image;
  if (image.channels() == 3 && rgb) cv::cvtColor(image, bgr, cv::COLOR_RGB2BGR);
  if (image.channels() == 4)
    cv::cvtColor(image, bgr, rgb ? cv::COLOR_RGBA2BGR : cv::COLOR_BGRA2BGR);
  scale = 1.0;
  if (bgr.cols > max_width) {
    scale = static_cast<double>(max_width) / bgr.cols;
    cv::Mat small;
    cv::resize(bgr, small, cv::Size(), scale, scale, cv::INTER_AREA);
    bgr = small;
  }
  std::vector<std::uint8_t> bytes;
  cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
  return {bytes.begin(), bytes.end()};
}

std::string frame_json(const system::FrameSnapshot& s, int width, int height) {
  nlohmann::json pose;
  if (s.state == system::ObservedState::kTracking ||
      s.state == system::ObservedState::kRelocalized ||
      s.state == system::ObservedState::kOdometry) {
    const Eigen::Quaterniond& q = s.world_from_cam.quaternion();
    const Eigen::Vector3d& t = s.world_from_cam.translation();
    pose = {q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()};
  }
  nlohmann::json kp = nlohmann::json::array();
  std::string tracked(s.tracked.size(), '0');
  for (std::size_t i = 0; i < s.keypoints.size(); ++i) {
    kp.push_back(std::lround(s.keypoints[i].x()));
    kp.push_back(std::lround(s.keypoints[i].y()));
    if (s.tracked[i] != 0) tracked[i] = '1';
  }
  const nlohmann::json j{
      {"index", s.index},       {"t", s.timestamp},  {"state", to_string(s.state)},
      {"keyframe", s.keyframe}, {"pose", pose},      {"inliers", s.inliers},
      {"track_ms", s.track_ms}, {"width", width},    {"height", height},
      {"keypoints", kp},        {"tracked", tracked}};
  return j.dump();
}

}  // namespace

void LiveFeedOptions::check() const {
  if (!(max_fps > 0.0)) throw Error("must be positive (frames per second)", {.field = "max_fps"});
  if (!(map_interval_s > 0.0))
    throw Error("must be positive (seconds)", {.field = "map_interval_s"});
  if (!(map_lock_share > 0.0 && map_lock_share <= 1.0))
    throw Error("must be in (0, 1]", {.field = "map_lock_share"});
  if (jpeg_quality < 1 || jpeg_quality > 100)
    throw Error("must be 1..100", {.field = "jpeg_quality"});
  if (max_image_width < 16) throw Error("must be at least 16 pixels", {.field = "max_image_width"});
}

LiveFeed::LiveFeed(ViewServer& server, LiveFeedOptions options, MapSnapshotFn map)
    : server_(server), options_(options), map_(std::move(map)) {
  options_.check();
  thread_ = std::thread([this] { run(); });
}

LiveFeed::~LiveFeed() {
  stop();
}

void LiveFeed::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool LiveFeed::wants_frame(double /*timestamp*/) {
  offered_.fetch_add(1, std::memory_order_relaxed);
  if (pages_.load(std::memory_order_relaxed) == 0 || busy_.load(std::memory_order_acquire))
    return false;
  const auto now = Clock::now();
  if (now - last_taken_ < std::chrono::duration<double>(1.0 / options_.max_fps)) return false;
  last_taken_ = now;
  return true;
}

void LiveFeed::on_frame(system::FrameSnapshot snapshot) {
  busy_.store(true, std::memory_order_release);
  {
    std::lock_guard lock(mutex_);
    mailbox_ = std::move(snapshot);
    ++stats_.frames_taken;
  }
  wake_.notify_one();
}

void LiveFeed::refresh_map() {
  {
    std::lock_guard lock(mutex_);
    refresh_ = true;
  }
  wake_.notify_one();
}

LiveFeedStats LiveFeed::stats() const {
  std::lock_guard lock(mutex_);
  LiveFeedStats s = stats_;
  s.frames_offered = offered_.load(std::memory_order_relaxed);
  return s;
}

void LiveFeed::publish_frame(const system::FrameSnapshot& s) {
  const Stopwatch watch;
  double scale = 1.0;
  std::string jpeg;
  if (!s.image.empty())
    jpeg = encode_jpeg(s.image, s.rgb, options_.jpeg_quality, options_.max_image_width, scale);
  const double encode_ms = watch.elapsed_ms();
  server_.set_live_image(std::move(jpeg));
  system::FrameSnapshot scaled_keypoints;
  const system::FrameSnapshot* out = &s;
  if (scale != 1.0) {
    // The page draws keypoints over the image it gets: in its (scaled) pixels.
    scaled_keypoints = s;
    for (auto& k : scaled_keypoints.keypoints)
      k *= static_cast<float>(scale);
    out = &scaled_keypoints;
  }
  server_.publish("frame", frame_json(*out, static_cast<int>(std::lround(s.image.cols * scale)),
                                      static_cast<int>(std::lround(s.image.rows * scale))));
  std::lock_guard lock(mutex_);
  ++stats_.frames_published;
  stats_.max_encode_ms = std::max(stats_.max_encode_ms, encode_ms);
}

void LiveFeed::snapshot_map() {
  const Stopwatch watch;
  MapScene scene = map_();
  const double copy_ms = watch.elapsed_ms();
  ++map_version_;
  server_.set_scene(scene_json(scene, map_version_), map_version_);
  std::lock_guard lock(mutex_);
  ++stats_.map_snapshots;
  stats_.max_map_copy_ms = std::max(stats_.max_map_copy_ms, copy_ms);
}

void LiveFeed::run() {
  auto last_map = Clock::now() - std::chrono::hours(1);
  double map_interval = options_.map_interval_s;
  std::size_t pages_before = 0;
  while (true) {
    std::optional<system::FrameSnapshot> frame;
    bool refresh = false;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(100),
                     [&] { return stop_ || mailbox_.has_value() || refresh_; });
      if (stop_) return;
      frame.swap(mailbox_);
      std::swap(refresh, refresh_);
    }
    const std::size_t pages = server_.clients();
    pages_.store(pages, std::memory_order_relaxed);
    if (frame) {
      publish_frame(*frame);
      busy_.store(false, std::memory_order_release);
    }
    if (!map_) continue;
    const bool newcomer = pages > pages_before;
    pages_before = pages;
    const auto now = Clock::now();
    if (refresh || newcomer ||
        (pages > 0 && now - last_map >= std::chrono::duration<double>(map_interval))) {
      const Stopwatch watch;
      snapshot_map();
      last_map = Clock::now();
      // Copying a big map takes longer: space the copies so they stay a small share of the time.
      map_interval =
          std::max(options_.map_interval_s, watch.elapsed_seconds() / options_.map_lock_share);
    }
  }
}

}  // namespace coloc::slam::view
