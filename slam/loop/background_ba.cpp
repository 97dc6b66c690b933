// The loop closer's global BA in the background (ORB-SLAM's RunGlobalBundleAdjustment): the
// whole map is copied out under the lock, optimized without it (abortable), and merged back.
// Tracking and local mapping went on meanwhile, so the merge moves what the BA did not see:
// keyframes added since follow their spanning-tree parent's change, points added since follow
// their reference keyframe's.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <unordered_set>

#include "slam/core/timing.hpp"
#include "slam/loop/correction.hpp"
#include "slam/loop/loop_closer.hpp"
#include "slam/mapping/ba_window.hpp"

namespace coloc::slam::loop {
namespace {

// Poses of keyframes outside the window, from their parents' (parents first: tree order).
void propagate_through_tree(map::Map& m, const std::unordered_map<KeyframeId, SE3>& before,
                            const std::unordered_set<KeyframeId>& optimized) {
  std::vector<KeyframeId> stack{m.first_keyframe()};
  std::unordered_set<KeyframeId> visited;
  while (!stack.empty()) {
    const KeyframeId k = stack.back();
    stack.pop_back();
    map::Keyframe* kf = m.keyframe(k);
    if (!kf || !visited.insert(k).second) continue;
    const map::Keyframe* parent = m.keyframe(kf->parent);
    if (!optimized.count(k) && parent) {
      // cam_from_parent stays what it was before the merge.
      kf->frame.cam_from_world =
          before.at(k) * before.at(parent->id).inverse() * parent->cam_from_world();
    }
    for (KeyframeId c : kf->children)
      stack.push_back(c);
  }
}

}  // namespace

void LoopCloser::global_ba() {
  mapping::BaWindow w;
  {
    std::lock_guard lock(shared_.mutex);
    std::vector<KeyframeId> all;
    for (const auto& [id, kf] : shared_.map.keyframes())
      all.push_back(id);
    std::sort(all.begin(), all.end());
    if (all.size() >= 2) w = mapping::make_window(shared_.map, all);
  }
  Stopwatch watch;
  optim::BundleResult result;
  if (!w.pose_ids.empty())
    result = optim::bundle_adjust(w.problem, w.intrinsics, options_.ba, &abort_ba_);
  const bool aborted = w.pose_ids.empty() || result.aborted || abort_ba_;
  if (!aborted) {
    if (mapper_) mapper_->pause();
    {
      std::lock_guard lock(shared_.mutex);
      map::Map& m = shared_.map;
      std::unordered_map<KeyframeId, SE3> before;
      for (const auto& [id, kf] : m.keyframes())
        before.emplace(id, kf.cam_from_world());
      mapping::apply_window(m, w, result);
      const std::unordered_set<KeyframeId> optimized(w.pose_ids.begin(), w.pose_ids.end());
      propagate_through_tree(m, before, optimized);
      // Points of the window took the BA's positions; the others follow their reference.
      std::unordered_set<MapPointId> skip(w.point_ids.begin(), w.point_ids.end());
      move_points_with_keyframes(m, before, skip);
    }
    if (mapper_) mapper_->resume();
  }
  const double ms = watch.elapsed_ms();
  spdlog::info("loop closing: global BA {} ({} keyframes, {} points, {} iterations, {:.0f} ms)",
               aborted ? "aborted" : "merged", w.pose_ids.size(), w.point_ids.size(),
               result.iterations, ms);
  {
    std::lock_guard lock(state_mutex_);
    ++stats_.global_ba_runs;
    if (aborted) ++stats_.global_ba_aborted;
    stats_.global_ba_ms.push_back(ms);
  }
  ba_running_ = false;
}

}  // namespace coloc::slam::loop
