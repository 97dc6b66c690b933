// LocalMapper's bundle adjustment (split from local_mapper.cpp for size).
#include <spdlog/spdlog.h>

#include <cmath>

#include "slam/core/timing.hpp"
#include "slam/map/shutter.hpp"
#include "slam/mapping/ba_window.hpp"
#include "slam/mapping/local_mapper.hpp"

namespace coloc::slam::mapping {

void LocalMapper::local_bundle_adjustment(KeyframeId current) {
  BaWindow w;
  const bool estimate = shared_.estimate_readout;
  {
    std::lock_guard lock(shared_.mutex);
    map::Map& m = shared_.map;
    if (!m.keyframe(current) || m.keyframe_count() < 2) return;
    std::vector<KeyframeId> local{current};
    for (KeyframeId k : m.covisible(current))
      local.push_back(k);
    // A keyframe tracked just before the readout last moved still has the old compensation.
    if (estimate) map::set_map_readout(m, shared_.readout);
    w = make_window(m, local);
  }
  if (estimate && w.pose_ids.size() >= options_.readout_min_keyframes) {
    optim::BundleProblem::Readout& r = w.problem.readout;
    r.estimate = true;
    r.current = shared_.readout;
    r.prior = readout_estimate_.value_or(r.current);
    r.prior_sigma = options_.readout_step;
    r.max = options_.readout_max;
  }
  Stopwatch watch;
  const optim::BundleResult result =
      optim::bundle_adjust(w.problem, w.intrinsics, options_.ba, &abort_ba_);
  const double ms = watch.elapsed_ms();
  {
    std::lock_guard lock(shared_.mutex);
    apply_window(shared_.map, w, result);
    if (w.problem.readout.estimate && !result.aborted)
      update_readout(w.problem.readout.current + result.readout_change);
  }
  LocalBaRun run{.points = w.problem.points.size(),
                 .observations = w.problem.observations.size(),
                 .iterations = result.iterations,
                 .timing = result.timing};
  for (const optim::BundleProblem::Pose& p : w.problem.poses)
    ++(p.fixed ? run.fixed_poses : run.free_poses);
  std::lock_guard slock(state_mutex_);
  ++stats_.ba_runs;
  stats_.ba_aborted += result.aborted ? 1 : 0;
  stats_.ba_ms.push_back(ms);
  stats_.ba.push_back(run);
}

void LocalMapper::update_readout(double estimate) {
  readout_estimate_ = estimate;
  if (std::abs(estimate - shared_.readout) < options_.readout_publish) return;
  // Every keyframe is compensated again (a turn of each keypoint's bearing: about 0.1 ms per
  // keyframe, rare once the estimate has settled), so that they all match the new readout.
  shared_.readout = estimate;
  map::set_map_readout(shared_.map, estimate);
  spdlog::debug("local mapping: rolling-shutter readout estimated {:.2f} ms", 1e3 * estimate);
}

}  // namespace coloc::slam::mapping
