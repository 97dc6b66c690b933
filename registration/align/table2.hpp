#pragma once
// The paper's Table 2 (Michiels et al. 2024, section 6) for one registration level: each view
// (a keyframe of the registered map, or a sampled frame of a test walk localized in it) matched
// against the scan rendered at its pose (match_views, scan_match.hpp), EPnP + RANSAC giving the
// pose the scan says the view has. Per view: the angle (degrees) and centre distance (cm)
// between the map's pose and that pose, and the median 2-D distance (pixels) between the view's
// features and their matches in the rendering at the map's pose (RANSAC inliers). Each is
// summarized by mean, std, P50 and P90 over the views that matched. With ground truth (the
// twin's), also the TRUE pose errors, which the paper could not measure.
#include <cstddef>
#include <vector>

#include "registration/align/refine.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::registration::align {

// The paper's columns: mean, population std, P50, P90 (numpy's interpolated quantiles).
struct Table2Stats {
  double mean = 0.0, std = 0.0, p50 = 0.0, p90 = 0.0;
  std::size_t n = 0;
};
Table2Stats table2_stats(const std::vector<double>& values);

struct Table2Row {
  std::size_t views = 0, matched = 0;
  Table2Stats angle_deg, distance_cm, offset_px;
  // Against ground truth (all zero without it): the poses' true angle and centre distance, the
  // EPnP poses' true centre distance, and the RMSE of the true centre distances (the TRUE
  // co-location error).
  Table2Stats true_angle_deg, true_distance_cm, pnp_true_distance_cm;
  double true_rmse_cm = 0.0;
};

// `refined`: match_views' result for the views. `estimated`: world_from_cam of the poses whose
// true error is measured (the views' own, or every localized frame of a test walk); empty: the
// views' registered poses. `truth`: world_from_cam in the scan frame, associated by timestamp
// (1 ms); empty: no true errors.
Table2Row table2_row(const std::vector<KeyframeRefinement>& refined, const Trajectory& estimated,
                     const Trajectory& truth);

// The views' registered poses as a trajectory (world_from_cam, by timestamp).
Trajectory registered_trajectory(const std::vector<KeyframeRefinement>& refined);

}  // namespace coloc::registration::align
