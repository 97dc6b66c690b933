// LoopOptions::check in an object of its own: what reads the options (the tuning table, and
// through it the localizer) links this, not the loop closer.
#include "slam/loop/loop_options.hpp"

#include "slam/core/error.hpp"

namespace coloc::slam::loop {

void LoopOptions::check() const {
  if (queue_capacity < 1) throw Error("LoopOptions.queue_capacity must be >= 1");
  if (max_candidates < 1) throw Error("LoopOptions.max_candidates must be >= 1");
  if (min_consistency < 0) throw Error("LoopOptions.min_consistency must be >= 0");
  if (min_bow_matches < 3) throw Error("LoopOptions.min_bow_matches must be >= 3");
  if (ransac_iterations < 1) throw Error("LoopOptions.ransac_iterations must be >= 1");
  if (min_ransac_inliers < 3) throw Error("LoopOptions.min_ransac_inliers must be >= 3");
  if (!(projection_radius_px > 0.0)) throw Error("LoopOptions.projection_radius_px must be > 0");
  if (projection_max_distance < 0 || projection_max_distance > 256)
    throw Error("LoopOptions.projection_max_distance must be in [0, 256]");
  if (min_inliers < min_ransac_inliers)
    throw Error("LoopOptions.min_inliers must be >= min_ransac_inliers");
  if (!(current_pose_radius_px > 0.0))
    throw Error("LoopOptions.current_pose_radius_px must be > 0");
  if (!(max_drift_m >= 0.0)) throw Error("LoopOptions.max_drift_m must be >= 0");
  if (!(max_drift_per_m >= 0.0)) throw Error("LoopOptions.max_drift_per_m must be >= 0");
  if (!(max_rotation_drift >= 0.0)) throw Error("LoopOptions.max_rotation_drift must be >= 0");
  if (!(max_rotation_drift_per_m >= 0.0))
    throw Error("LoopOptions.max_rotation_drift_per_m must be >= 0");
  if (!(max_free_space_violation >= 0.0 && max_free_space_violation <= 1.0))
    throw Error("LoopOptions.max_free_space_violation must be in [0, 1]");
  if (min_free_space_samples < 1) throw Error("LoopOptions.min_free_space_samples must be >= 1");
  free_space.check();
  if (!(fusion_radius_px > 0.0)) throw Error("LoopOptions.fusion_radius_px must be > 0");
  if (strong_covisibility < 1) throw Error("LoopOptions.strong_covisibility must be >= 1");
  if (graph_iterations < 1) throw Error("LoopOptions.graph_iterations must be >= 1");
  ba.check();
}

}  // namespace coloc::slam::loop
