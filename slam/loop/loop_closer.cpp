#include "slam/loop/loop_closer.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <unordered_set>

#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/loop/correction.hpp"
#include "slam/mapping/ba_window.hpp"

namespace coloc::slam::loop {

LoopCloser::LoopCloser(map::SharedMap& map, LoopOptions options, std::optional<Camera> depth_camera)
    : shared_(map),
      options_(options),
      depth_camera_(std::move(depth_camera)),
      queue_(options_.queue_capacity),
      detector_(options_) {
  options_.check();
}

LoopCloser::~LoopCloser() {
  stop();
}

void LoopCloser::start(mapping::LocalMapper* mapper) {
  mapper_ = mapper;
  if (!thread_.joinable() && !stopping_) thread_ = std::thread([this] { run(); });
}

bool LoopCloser::push(map::KeyframeMessage message) {
  return queue_.push(std::move(message));
}

bool LoopCloser::idle() const {
  return queue_.idle();
}

void LoopCloser::wait_idle() {
  queue_.wait_idle();
}

void LoopCloser::stop() {
  stopping_ = true;
  queue_.close();
  if (thread_.joinable()) thread_.join();
  abort_ba_ = true;
  if (ba_thread_.joinable()) ba_thread_.join();
}

LoopStats LoopCloser::stats() const {
  std::lock_guard lock(state_mutex_);
  return stats_;
}

void LoopCloser::wait_global_ba() {
  if (ba_thread_.joinable()) ba_thread_.join();
}

void LoopCloser::run() {
  for (;;) {
    KeyframeId id;
    if (!backlog_.empty()) {
      id = backlog_.front();
      backlog_.pop_front();
    } else if (auto message = queue_.pop()) {
      id = message->id;
    } else {
      break;
    }
    try {
      process(id);
    } catch (const std::exception& e) {
      // A failed keyframe must not take the thread (and the program) down.
      spdlog::error("loop closing: keyframe {}: {}", id.value(), e.what());
    }
    queue_.finished();
  }
}

void LoopCloser::process(KeyframeId current) {
  std::size_t examined = 0;
  {
    std::lock_guard lock(state_mutex_);
    examined = static_cast<std::size_t>(++stats_.keyframes);
  }
  Detection detection;
  {
    std::lock_guard lock(shared_.mutex);
    if (shared_.map.keyframe_count() < options_.min_keyframes) return;
    if (last_loop_kf_count_ > 0 && examined < last_loop_kf_count_ + options_.keyframes_after_loop)
      return;
    if (!shared_.database.contains(current.value())) return;
    detection = detector_.detect(shared_.map, shared_.database, current);
  }
  if (!detection.consistent.empty() && try_close(current, detection))
    last_loop_kf_count_ = examined;
}

bool LoopCloser::try_close(KeyframeId current, const Detection& detection) {
  std::vector<LoopCandidate> candidates = detection.consistent;
  std::sort(candidates.begin(), candidates.end(),
            [](const auto& a, const auto& b) { return a.score > b.score; });
  for (const LoopCandidate& c : candidates) {
    LoopVerification v;
    {
      std::lock_guard lock(shared_.mutex);
      v = verify_loop(shared_.map, current, c.keyframe, options_, rng_,
                      depth_camera_ ? &*depth_camera_ : nullptr);
    }
    {
      std::lock_guard lock(state_mutex_);
      ++stats_.candidates;
      if (!v.accepted) ++stats_.rejected;
      if (v.implausible) ++stats_.rejected_aliasing;
      if (v.look_alike) ++stats_.rejected_look_alike;
      if (v.hypothesis_moved_m > options_.max_drift_m) ++stats_.shifted_by_current_pose;
    }
    if (!v.accepted) {
      // Rejections are routine (the summary counts them); each one's figures are for debugging.
      spdlog::debug(
          "loop rejected: keyframe {} -> {}: {} (score {:.3f}, min {:.3f}, consistency {}, bow "
          "{}, ransac {}, inliers {}, at the current pose {} (moved {:.3f} m), correction "
          "{:.3f} m / {:.3f} rad, allowed {:.3f} m / {:.3f} rad over {:.2f} m, depth: {} agree, "
          "{} in free space, worst pair {:.2f} %, {:.1f} ms)",
          current.value(), c.keyframe.value(), v.rejection, c.score, detection.min_score,
          c.consistency, v.bow_matches, v.ransac_inliers, v.inliers, v.current_pose_inliers,
          v.hypothesis_moved_m, v.correction_m, v.correction_rad, v.allowed_m, v.allowed_rad,
          v.path_m, v.free_space.agree, v.free_space.violate, 100.0 * v.free_space.worst_pair,
          v.free_space_ms);
      continue;
    }
    correct(v, c);
    return true;
  }
  return false;
}

void LoopCloser::pause_for_correction() {
  abort_ba_ = true;
  if (mapper_) mapper_->request_pause();
  while (auto m = queue_.size() > 0 ? queue_.pop() : std::nullopt)
    backlog_.push_back(m->id);
  if (ba_thread_.joinable()) ba_thread_.join();
  if (mapper_) mapper_->wait_paused();
}

void LoopCloser::correct(const LoopVerification& v, const LoopCandidate& c) {
  Stopwatch watch;
  pause_for_correction();
  CorrectionReport report;
  LoopRecord r;
  {
    std::lock_guard lock(shared_.mutex);
    if (const map::Keyframe* kf = shared_.map.keyframe(v.current))
      r.current_time = kf->frame.timestamp;
    if (const map::Keyframe* kf = shared_.map.keyframe(c.keyframe)) {
      r.candidate_time = kf->frame.timestamp;
      r.candidate_from_current = kf->cam_from_world() * v.corrected_cam_from_world.inverse();
    }
    report = correct_loop(shared_.map, v, options_);
  }
  if (mapper_) mapper_->resume();
  detector_.reset();
  r.current = v.current;
  r.candidate = c.keyframe;
  r.score = c.score;
  r.consistency = c.consistency;
  r.bow_matches = v.bow_matches;
  r.ransac_inliers = v.ransac_inliers;
  r.inliers = v.inliers;
  r.current_pose_inliers = v.current_pose_inliers;
  r.hypothesis_moved_m = v.hypothesis_moved_m;
  r.path_m = v.path_m;
  r.correction_m = v.correction_m;
  r.correction_rad = v.correction_rad;
  r.free_space = v.free_space;
  r.fused = report.fused;
  r.ms = watch.elapsed_ms();
  spdlog::info(
      "loop closed: keyframe {} -> {} (score {:.3f}, consistency {}, bow {}, ransac {}, inliers "
      "{}, at the current pose {} (moved {:.3f} m), correction {:.3f} m / {:.4f} rad over "
      "{:.2f} m of path, depth {} agree / {} in free space (worst pair {:.2f} %), {} "
      "neighbours moved, {} replaced, {} fused, {} loop connections, essential graph {} "
      "keyframes / {} edges, {:.1f} ms)",
      r.current.value(), r.candidate.value(), r.score, r.consistency, r.bow_matches,
      r.ransac_inliers, r.inliers, r.current_pose_inliers, r.hypothesis_moved_m, r.correction_m,
      r.correction_rad, r.path_m, r.free_space.agree, r.free_space.violate,
      100.0 * r.free_space.worst_pair, report.corrected_neighbours, report.replaced, report.fused,
      report.loop_connections, report.graph_keyframes, report.graph_edges, r.ms);
  {
    std::lock_guard lock(state_mutex_);
    stats_.loops.push_back(r);
  }
  if (options_.global_ba && !stopping_) start_global_ba();
}

void LoopCloser::start_global_ba() {
  if (ba_thread_.joinable()) ba_thread_.join();
  abort_ba_ = false;
  ba_running_ = true;
  ba_thread_ = std::thread([this] { global_ba(); });
}

}  // namespace coloc::slam::loop
