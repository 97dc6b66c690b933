#include "registration/align/table2.hpp"

#include <cmath>

#include "registration/align/scan_match.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::align {
namespace {

// Views and truth are the same frames: their timestamps agree to the file's precision.
constexpr double kAssociationSeconds = 1e-3;

}  // namespace

Table2Stats table2_stats(const std::vector<double>& values) {
  Table2Stats s;
  s.n = values.size();
  if (values.empty()) return s;
  const SampleStats summary = summarize(values);
  s.mean = summary.mean;
  s.std = summary.stddev;
  s.p50 = summary.median;
  s.p90 = quantile(values, 0.9);
  return s;
}

Trajectory registered_trajectory(const std::vector<KeyframeRefinement>& refined) {
  Trajectory t;
  t.reserve(refined.size());
  for (const auto& k : refined)
    t.push_back({k.timestamp, k.registered.inverse()});
  return t;
}

Table2Row table2_row(const std::vector<KeyframeRefinement>& refined, const Trajectory& estimated,
                     const Trajectory& truth) {
  Table2Row row;
  row.views = refined.size();
  std::vector<double> angle, distance, offset;
  for (const auto& k : refined) {
    if (!k.accepted) continue;
    ++row.matched;
    angle.push_back(k.correction_deg);
    distance.push_back(100.0 * k.correction_m);
    offset.push_back(k.median_offset_px);
  }
  row.angle_deg = table2_stats(angle);
  row.distance_cm = table2_stats(distance);
  row.offset_px = table2_stats(offset);
  if (truth.empty()) return row;

  const Trajectory views = registered_trajectory(refined);
  const Trajectory& poses = estimated.empty() ? views : estimated;
  std::vector<double> true_angle, true_distance, pnp_distance;
  double sum_sq = 0.0;
  for (const auto& [i, j] : associate_by_time(poses, truth, kAssociationSeconds)) {
    const SE3 cam_from_world = poses[i].world_from_cam.inverse();
    const SE3 true_cam_from_world = truth[j].world_from_cam.inverse();
    true_angle.push_back(pose_angle_deg(cam_from_world, true_cam_from_world));
    true_distance.push_back(100.0 * pose_distance_m(cam_from_world, true_cam_from_world));
    sum_sq += true_distance.back() * true_distance.back();
  }
  if (!true_distance.empty())
    row.true_rmse_cm = std::sqrt(sum_sq / static_cast<double>(true_distance.size()));
  for (const auto& [i, j] : associate_by_time(views, truth, kAssociationSeconds)) {
    if (refined[i].accepted)
      pnp_distance.push_back(100.0 *
                             pose_distance_m(refined[i].pnp, truth[j].world_from_cam.inverse()));
  }
  row.true_angle_deg = table2_stats(true_angle);
  row.true_distance_cm = table2_stats(true_distance);
  row.pnp_true_distance_cm = table2_stats(pnp_distance);
  return row;
}

}  // namespace coloc::registration::align
