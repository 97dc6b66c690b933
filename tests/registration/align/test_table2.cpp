// Table 2's metrics (registration/align/table2.hpp) on views whose corrections and true errors
// are known: the paper's columns (mean, population std, P50, P90 as numpy interpolates them)
// over the matched views only, and the true errors of the poses against ground truth.
#include <gtest/gtest.h>

#include <cmath>

#include "registration/align/table2.hpp"

namespace coloc::registration::align {
namespace {

KeyframeRefinement view(double timestamp, bool accepted, double correction_cm, double deg,
                        double offset_px, const SE3& cam_from_world) {
  KeyframeRefinement k;
  k.timestamp = timestamp;
  k.accepted = accepted;
  k.correction_m = correction_cm / 100.0;
  k.correction_deg = deg;
  k.median_offset_px = offset_px;
  k.registered = cam_from_world;
  k.pnp = cam_from_world;
  k.has_pose = accepted;
  return k;
}

TEST(Table2, StatsAreNumpysMeanStdAndInterpolatedQuantiles) {
  // numpy: mean 2.5, std (ddof=0) 1.1180, percentile 50 -> 2.5, 90 -> 3.7.
  const Table2Stats s = table2_stats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.n, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_NEAR(s.std, std::sqrt(1.25), 1e-12);
  EXPECT_DOUBLE_EQ(s.p50, 2.5);
  EXPECT_NEAR(s.p90, 3.7, 1e-12);
  const Table2Stats empty = table2_stats({});
  EXPECT_EQ(empty.n, 0u);
  EXPECT_EQ(empty.mean, 0.0);
}

TEST(Table2, OnlyMatchedViewsEnterThePaperColumns) {
  const std::vector<KeyframeRefinement> views = {
      view(0.0, true, 1.0, 0.1, 0.5, SE3()), view(1.0, true, 3.0, 0.3, 1.5, SE3()),
      view(2.0, false, 50.0, 9.0, 40.0, SE3())};  // not matched: left out
  const Table2Row row = table2_row(views, {}, {});
  EXPECT_EQ(row.views, 3u);
  EXPECT_EQ(row.matched, 2u);
  EXPECT_DOUBLE_EQ(row.distance_cm.mean, 2.0);
  EXPECT_DOUBLE_EQ(row.angle_deg.p50, 0.2);
  EXPECT_DOUBLE_EQ(row.offset_px.mean, 1.0);
  EXPECT_EQ(row.true_distance_cm.n, 0u);  // no ground truth, no true errors
  EXPECT_EQ(row.true_rmse_cm, 0.0);
}

TEST(Table2, TrueErrorsAgainstGroundTruthByTimestamp) {
  // Every view 3 cm off in x, then 4 cm off in y: RMSE of the centre distances 3.54 cm.
  Trajectory truth;
  std::vector<KeyframeRefinement> views;
  for (int i = 0; i < 4; ++i) {
    const SE3 world_from_cam(SO3::exp({0.0, 0.0, 0.1 * i}), Eigen::Vector3d(0.5 * i, 0.0, 1.5));
    truth.push_back({1.0 + i, world_from_cam});
    const Eigen::Vector3d off =
        i < 2 ? Eigen::Vector3d(0.03, 0.0, 0.0) : Eigen::Vector3d(0.0, 0.04, 0.0);
    const SE3 estimated(world_from_cam.so3(), world_from_cam.translation() + off);
    views.push_back(view(1.0 + i, true, 0.0, 0.0, 0.0, estimated.inverse()));
  }
  truth.push_back({10.0, SE3()});  // no view at this time: not associated
  const Table2Row row = table2_row(views, {}, truth);
  EXPECT_EQ(row.true_distance_cm.n, 4u);
  EXPECT_NEAR(row.true_distance_cm.p50, 3.5, 1e-9);
  EXPECT_NEAR(row.true_rmse_cm, std::sqrt((2 * 9.0 + 2 * 16.0) / 4.0), 1e-9);
  EXPECT_NEAR(row.true_angle_deg.mean, 0.0, 1e-9);
  EXPECT_NEAR(row.pnp_true_distance_cm.mean, 3.5, 1e-9);  // the PnP poses are the views' here

  // A test walk: the true error is measured on its own trajectory, not on the sampled views.
  Trajectory walk;
  for (const auto& p : truth)
    walk.push_back({p.timestamp, SE3(p.world_from_cam.so3(), p.world_from_cam.translation() +
                                                                 Eigen::Vector3d(0, 0, 0.01))});
  const Table2Row walked = table2_row(views, walk, truth);
  EXPECT_EQ(walked.true_distance_cm.n, 5u);
  EXPECT_NEAR(walked.true_rmse_cm, 1.0, 1e-9);
}

}  // namespace
}  // namespace coloc::registration::align
