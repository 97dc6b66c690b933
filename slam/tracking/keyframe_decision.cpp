// The tracker's keyframe decision (ORB-SLAM2's NeedNewKeyFrame with coloc's rules: early
// keyframes paced by motion, deferral from blurred or off-model frames, the weak-reference
// replacement) and the making of a keyframe from the current frame.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "slam/map/keyframe_depth.hpp"
#include "slam/matching/pose_support.hpp"
#include "slam/tracking/tracker.hpp"

namespace coloc::slam::tracking {

Tracker::KeyframeNeed Tracker::need_keyframe() const {
  const map::Map& m = shared_.map;
  if (!sink_ || !sink_->accepting()) return KeyframeNeed::kNo;
  const std::size_t n_kfs = m.keyframe_count();
  const std::uint64_t since_reloc =
      last_reloc_frame_.valid() ? current_.id.value() - last_reloc_frame_.value() : ~0ULL;
  const auto max_frames = static_cast<std::uint64_t>(options_.max_frames_between_keyframes);
  if (since_reloc < max_frames && n_kfs > max_frames &&
      matches_inliers_ >= options_.reloc_pause_min_inliers)
    return KeyframeNeed::kNo;
  const map::Keyframe* ref = m.keyframe(reference_);
  if (!ref) return KeyframeNeed::kYes;
  const int min_obs = n_kfs <= 2 ? 2 : 3;
  int ref_matches = 0;
  for (MapPointId p : ref->frame.points) {
    if (p.valid() && m.point(p) && m.weighted_observations(p) >= min_obs) ++ref_matches;
  }
  const bool mapping_idle = sink_->idle();
  int tracked_close = 0, untracked_close = 0;
  for (std::size_t i = 0; i < current_.size(); ++i) {
    if (!current_.is_close(i)) continue;
    if (current_.points[i].valid() && !current_.outlier[i]) {
      ++tracked_close;
    } else {
      ++untracked_close;
    }
  }
  const bool need_close = tracked_close < options_.close_tracked_limit &&
                          untracked_close > options_.close_untracked_limit;
  const double ref_ratio = n_kfs < 2 ? 0.4 : options_.reference_ratio;
  // No keyframe of this tracker yet (relocalized into a loaded map): as if long ago.
  const std::uint64_t since_kf =
      last_keyframe_frame_.valid() ? current_.id.value() - last_keyframe_frame_.value() : ~0ULL;
  const bool c1a = since_kf >= max_frames;
  // TrackingOptions::min_frames_between_keyframes: the mapper's state only with
  // keyframe_needs_idle_mapper; a busy one has its BA interrupted below.
  const bool c1b = since_kf >= static_cast<std::uint64_t>(min_frames_for_keyframe()) &&
                   (mapping_idle || !options_.keyframe_needs_idle_mapper);
  const bool c1c = matches_inliers_ < ref_matches * 0.25 || need_close;
  // The reference is a keyframe this tracker made from a far weaker frame (blurred, or at the
  // edge of the map): TrackingOptions::weak_reference_ratio.
  const bool weak_reference =
      options_.weak_reference_ratio > 0.0 && reference_ == last_keyframe_ &&
      matches_inliers_ > options_.weak_reference_ratio * last_keyframe_inliers_;
  const bool c2 = (matches_inliers_ < ref_matches * ref_ratio || need_close || weak_reference) &&
                  matches_inliers_ > 15;
  // The rule's inputs, to compare keyframe decisions with ORB-SLAM2's (docs/results).
  spdlog::debug("tracking: frame {} keyframe rule: {} inliers, reference {} has {}, close {} / {}",
                current_.id.value(), matches_inliers_, reference_.value(), ref_matches,
                tracked_close, untracked_close);
  if (!((c1a || c1b || c1c) && c2)) return KeyframeNeed::kNo;
  if (mapping_idle) return KeyframeNeed::kYes;
  sink_->interrupt();
  return sink_->queued() < 3 ? KeyframeNeed::kYes : KeyframeNeed::kMapperBusy;
}

int Tracker::min_frames_for_keyframe() const {
  double turned_deg = 0.0, moved_m = 0.0;
  for (const auto& [deg, m] : recent_motion_) {
    turned_deg += deg;
    moved_m += m;
  }
  const bool moved = turned_deg >= options_.early_keyframe_rotation_deg ||
                     moved_m >= options_.early_keyframe_translation_m;
  return moved ? options_.min_frames_between_keyframes
               : std::max(options_.min_frames_between_keyframes,
                          options_.min_frames_between_slow_keyframes);
}

bool Tracker::defer_keyframe() {
  const int best = *std::max_element(recent_inliers_.begin(), recent_inliers_.end());
  const bool weak = keyframes_deferred_ < options_.keyframe_defer_max &&
                    matches_inliers_ < options_.keyframe_defer_ratio * best;
  const bool off_course = options_.keyframe_defer_deviation_deg > 0.0 &&
                          keyframes_deferred_ < options_.keyframe_defer_deviation_max &&
                          deviation_deg_ > options_.keyframe_defer_deviation_deg;
  if (weak || off_course) {
    ++keyframes_deferred_;
    spdlog::debug(
        "tracking: frame {} keyframe deferred ({} inliers, {} in a frame before; {:.1f} deg off "
        "the motion model)",
        current_.id.value(), matches_inliers_, best, deviation_deg_);
    return true;
  }
  keyframes_deferred_ = 0;
  return false;
}

KeyframeId Tracker::add_current_keyframe() {
  compute_bow(current_);
  map::Keyframe kf;
  kf.id = shared_.map.next_keyframe_id();
  kf.frame = current_;
  if (options_.keyframe_depth_factor > 0 && current_depth_.type() == CV_32FC1 &&
      !current_depth_.empty() && current_depth_.cols >= options_.keyframe_depth_factor &&
      current_depth_.rows >= options_.keyframe_depth_factor)
    kf.depth =
        map::downsample_depth(current_depth_.ptr<float>(), current_depth_.cols, current_depth_.rows,
                              current_depth_.step1(), options_.keyframe_depth_factor);
  // While the readout is estimated, a keyframe is compensated with the rate of its poses, not
  // the one refined from its rows' shear: a refined rate fits the shear at whatever readout
  // tracking had (rate x readout is what the image shows), so a map of such keyframes looks
  // right at any readout and its local BAs cannot tell where the readout is. Paced, interleaved
  // (with the first keyframe's rate, since limited to a known readout): fr1/rpy, ORB-SLAM3 file,
  // median 14.5 -> 13.4 mm over 10; the twin room without the key 6.4 -> 4.5 mm. Sequential
  // fr1/rpy, ORB-SLAM3 file: 14.67 -> 13.04 mm. With a known readout the refined rate
  // stays (our TUM1 file, paced: 13.5 mm with it, 15.4 without).
  if (shared_.estimate_readout && !pose_rate_.isZero()) kf.frame.set_shutter_rate(pose_rate_);
  return shared_.map.add_keyframe(std::move(kf)).id;
}

void Tracker::create_keyframe() {
  map::Map& m = shared_.map;
  if (!options_.keyframe_keeps_outliers) matching::drop_outliers(current_);
  const KeyframeId id = add_current_keyframe();
  // The keyframe observes its outlier matches as plain observations: its BA decides them.
  std::vector<std::uint8_t>& outlier = m.keyframe(id)->frame.outlier;
  std::fill(outlier.begin(), outlier.end(), std::uint8_t{0});
  // New points from depth: every close keypoint without a point, then far ones up to a quota.
  std::vector<std::pair<float, std::size_t>> by_depth;
  for (std::size_t i = 0; i < current_.size(); ++i) {
    if (current_.has_depth(i)) by_depth.emplace_back(current_.depth[i], i);
  }
  std::sort(by_depth.begin(), by_depth.end());
  int considered = 0;
  map::Keyframe* stored = m.keyframe(id);
  for (const auto& [d, i] : by_depth) {
    const MapPointId existing = stored->frame.points[i];
    const map::MapPoint* mp = existing.valid() ? m.point(existing) : nullptr;
    if (!mp || mp->observations.size() < 1) {
      const MapPointId p =
          m.add_point(current_.unproject_world(i), id, static_cast<std::uint32_t>(i)).id;
      current_.points[i] = p;
    }
    ++considered;
    if (d > geometry_->close_depth && considered > options_.new_points_min) break;
  }
  m.update_connections(id);
  reference_ = id;
  last_keyframe_frame_ = current_.id;
  last_keyframe_ = id;
  last_keyframe_inliers_ = matches_inliers_;
}

}  // namespace coloc::slam::tracking
