#include "slam/mapping/local_mapper.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include "markers/detector.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/mapping/triangulate.hpp"
#include "slam/matching/fuse.hpp"

namespace coloc::slam::mapping {

LocalMapper::LocalMapper(map::SharedMap& map, const bow::Vocabulary& vocabulary,
                         const markers::MarkerDetector* detector, double marker_size,
                         LocalMappingOptions options, map::KeyframeSink* output)
    : shared_(map),
      vocabulary_(vocabulary),
      detector_(detector),
      marker_size_(marker_size),
      options_(options),
      output_(output),
      queue_(options_.queue_capacity) {
  options_.check();
}

LocalMapper::~LocalMapper() {
  stop();
}

void LocalMapper::start() {
  if (!thread_.joinable() && !stopping_) thread_ = std::thread([this] { run(); });
}

bool LocalMapper::push(map::KeyframeMessage message) {
  return queue_.push(std::move(message));
}

bool LocalMapper::idle() const {
  return queue_.idle();
}

void LocalMapper::wait_idle() {
  queue_.wait_idle();
  // Sequential mode means the whole chain behind tracking has finished the keyframe.
  if (output_) output_->wait_idle();
}

void LocalMapper::pause() {
  request_pause();
  wait_paused();
}

void LocalMapper::request_pause() {
  std::lock_guard lock(state_mutex_);
  ++pause_requests_;
  pause_requested_ = true;
  abort_ba_ = true;
}

void LocalMapper::wait_paused() {
  std::unique_lock lock(state_mutex_);
  // The thread takes a keyframe in hand only under state_mutex_ and after checking the request,
  // so once processing_ is false here it stays false until resume().
  state_cv_.wait(lock, [&] { return !processing_; });
}

void LocalMapper::resume() {
  std::lock_guard lock(state_mutex_);
  if (pause_requests_ > 0) --pause_requests_;
  pause_requested_ = pause_requests_ > 0;
  state_cv_.notify_all();
}

bool LocalMapper::paused() const {
  std::lock_guard lock(state_mutex_);
  return pause_requested_ && !processing_;
}

void LocalMapper::stop() {
  {
    std::lock_guard lock(state_mutex_);
    stopping_ = true;
    abort_ba_ = true;
    state_cv_.notify_all();
  }
  queue_.close();
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(state_mutex_);
  state_cv_.notify_all();
}

MappingStats LocalMapper::stats() const {
  std::lock_guard lock(state_mutex_);
  return stats_;
}

void LocalMapper::take_in_hand() {
  std::unique_lock lock(state_mutex_);
  state_cv_.wait(lock, [&] { return !pause_requested_ || stopping_; });
  processing_ = true;
}

void LocalMapper::run() {
  while (auto message = queue_.pop()) {
    take_in_hand();
    try {
      process(*message);
    } catch (const std::exception& e) {
      // A failed keyframe must not take the thread (and the program) down.
      spdlog::error("local mapping: keyframe {}: {}", message->id.value(), e.what());
    }
    // The stage behind mapping (a loop closer) sees keyframes in the order they were mapped.
    if (output_ && !stopping_) output_->push({message->id, {}});
    {
      std::lock_guard lock(state_mutex_);
      processing_ = false;
      state_cv_.notify_all();
    }
    queue_.finished();
  }
}

void LocalMapper::process(const map::KeyframeMessage& message) {
  const Stopwatch watch;
  insert_keyframe(message);
  cull_recent_points(message.id);
  if (options_.triangulation) {
    std::lock_guard lock(shared_.mutex);
    if (shared_.map.keyframe(message.id)) {
      const auto created = triangulate_with_neighbours(shared_.map, message.id,
                                                       shared_.map.covisible(message.id, 10));
      recent_points_.insert(recent_points_.end(), created.begin(), created.end());
      std::lock_guard slock(state_mutex_);
      stats_.points_triangulated += static_cast<int>(created.size());
    }
  }
  fuse_neighbours(message.id);
  // ORB-SLAM skips BA while keyframes wait: tracking needs them in the map first.
  if (options_.local_ba && queue_.size() == 0 && !stopping_ && !pause_requested_) {
    abort_ba_ = false;
    local_bundle_adjustment(message.id);
  }
  if (options_.keyframe_culling) cull_keyframes(message.id);
  std::lock_guard lock(state_mutex_);
  ++stats_.keyframes;
  stats_.keyframe_ms.push_back(watch.elapsed_ms());
}

void LocalMapper::insert_keyframe(const map::KeyframeMessage& message) {
  std::vector<features::Descriptor> descriptors;
  bool need_bow = false;
  {
    std::lock_guard lock(shared_.mutex);
    const map::Keyframe* kf = shared_.map.keyframe(message.id);
    if (!kf) return;
    need_bow = kf->frame.bow.empty();
    if (need_bow) descriptors = kf->frame.features.descriptors;
  }
  bow::BowVector bow;
  bow::FeatureVector fv;
  if (need_bow) vocabulary_.transform(descriptors, bow, fv);
  std::vector<markers::MarkerObservation> found;
  if (detector_ && !message.grey.empty()) found = detector_->detect(message.grey);

  std::lock_guard lock(shared_.mutex);
  map::Map& m = shared_.map;
  map::Keyframe* kf = m.keyframe(message.id);
  if (!kf) return;
  if (need_bow) {
    kf->frame.bow = std::move(bow);
    kf->frame.feature_vector = std::move(fv);
  }
  kf->markers = std::move(found);
  kf->marker_size = kf->markers.empty() ? 0.0 : marker_size_;
  if (!shared_.database.contains(message.id.value()))
    shared_.database.add(message.id.value(), kf->frame.bow);
  for (MapPointId p : kf->frame.points) {
    const map::MapPoint* mp = p.valid() ? m.point(p) : nullptr;
    if (!mp) continue;
    if (mp->first_keyframe == message.id) recent_points_.push_back(p);
    m.update_point(p);
  }
  m.update_connections(message.id);
  std::lock_guard slock(state_mutex_);
  stats_.markers += static_cast<int>(kf->markers.size());
}

void LocalMapper::cull_recent_points(KeyframeId current) {
  std::lock_guard lock(shared_.mutex);
  map::Map& m = shared_.map;
  int culled = 0;
  std::vector<MapPointId> keep;
  for (MapPointId id : recent_points_) {
    map::MapPoint* p = m.point(id);
    if (!p) continue;
    // ORB-SLAM2 counts a stereo-like observation twice; RGB-D points need more than 3.
    const int weighted = m.weighted_observations(id);
    const auto age = static_cast<std::int64_t>(current.value()) -
                     static_cast<std::int64_t>(p->first_keyframe.value());
    if (p->found_ratio() < 0.25 || (age >= 2 && weighted <= 3)) {
      m.erase_point(id);
      ++culled;
    } else if (age < 3) {
      keep.push_back(id);
    }
  }
  recent_points_ = std::move(keep);
  std::lock_guard slock(state_mutex_);
  stats_.points_culled += culled;
}

void LocalMapper::fuse_neighbours(KeyframeId current) {
  std::lock_guard lock(shared_.mutex);
  map::Map& m = shared_.map;
  if (!m.keyframe(current)) return;
  std::vector<KeyframeId> targets = m.covisible(current, options_.fusion_neighbours);
  std::set<KeyframeId> seen(targets.begin(), targets.end());
  for (KeyframeId k : std::vector<KeyframeId>(targets)) {
    for (KeyframeId k2 : m.covisible(k, 5)) {
      if (k2 != current && seen.insert(k2).second) targets.push_back(k2);
    }
  }
  int fused = 0;
  for (KeyframeId t : targets) {
    const map::Keyframe* kf = m.keyframe(current);
    if (!kf) break;
    std::vector<MapPointId> pts;
    for (MapPointId p : kf->frame.points)
      if (p.valid()) pts.push_back(p);
    fused += matching::fuse_points(m, t, pts, options_.fusion_radius);
  }
  std::vector<MapPointId> candidates;
  std::unordered_set<MapPointId> unique;
  for (KeyframeId t : targets) {
    const map::Keyframe* kf = m.keyframe(t);
    if (!kf) continue;
    for (MapPointId p : kf->frame.points) {
      if (p.valid() && unique.insert(p).second) candidates.push_back(p);
    }
  }
  fused += matching::fuse_points(m, current, candidates, options_.fusion_radius);
  const map::Keyframe* kf = m.keyframe(current);
  if (!kf) return;
  for (MapPointId p : kf->frame.points)
    if (p.valid() && m.point(p)) m.update_point(p);
  m.update_connections(current);
  std::lock_guard slock(state_mutex_);
  stats_.points_fused += fused;
}

}  // namespace coloc::slam::mapping
