// Our dense-Schur Levenberg-Marquardt against Ceres on the same bundle problems: the optimum,
// the outliers it flags, the rolling-shutter readout, fixed and unobserved poses, degenerate
// points, and the abort flag.
#include <gtest/gtest.h>

#include "slam/optim/bundle_adjustment.hpp"
#include "slam/optim/dense_schur_lm.hpp"
#include "tests/slam/optim/bundle_window.hpp"

namespace coloc::slam::optim {
namespace {

BundleOptions converging() {
  BundleOptions options;
  options.iterations_robust = 30;
  options.iterations_refine = 30;
  return options;
}

TEST(DenseSchur, ReachesCeresOptimumAndFlagsTheSameOutliers) {
  for (const bool readout : {false, true}) {
    Window w = make_window({.poses = 12, .seed = 11});
    w.problem.readout.estimate = readout;
    w.problem.readout.prior_sigma = 0.005;
    BundleProblem ceres = w.problem;
    BundleOptions ceres_options = converging();
    ceres_options.own_dense_solver = false;
    const BundleResult ours = bundle_adjust(w.problem, kTestK, converging());
    const BundleResult theirs = bundle_adjust(ceres, kTestK, ceres_options);
    EXPECT_EQ(ours.outlier, theirs.outlier) << "readout " << readout;
    std::size_t flagged = 0;
    for (const std::uint8_t o : ours.outlier)
      flagged += o;
    EXPECT_GT(flagged, 20u);
    EXPECT_NEAR(ours.final_cost, theirs.final_cost, 1e-10 * theirs.final_cost);
    EXPECT_NEAR(ours.readout_change, theirs.readout_change, 1e-9);
    if (readout) {
      EXPECT_GT(std::abs(ours.readout_change), 1e-4);  // the shear is not noise
    }
    // The same steps and the same stopping rules: the same estimate, to rounding.
    for (std::size_t i = 0; i < w.truth.size(); ++i) {
      EXPECT_LT(
          translation_distance(w.problem.poses[i].cam_from_world, ceres.poses[i].cam_from_world),
          1e-9)
          << i;
      EXPECT_LT(translation_distance(w.problem.poses[i].cam_from_world, w.truth[i]), 0.01) << i;
    }
    for (std::size_t j = 0; j < w.problem.points.size(); ++j) {
      ASSERT_TRUE(w.problem.points[j].allFinite()) << j;
      if (j % 50 != 0) {
        EXPECT_LT((w.problem.points[j] - ceres.points[j]).norm(), 1e-8) << j;
      }
    }
  }
}

TEST(DenseSchur, LeavesFixedAndUnobservedPosesWhereTheyAre) {
  Window w = make_window({.poses = 6, .seed = 3});
  // One free pose more that no observation reaches: it is no unknown of this solve.
  const SE3 lonely(SO3::exp({0.2, 0.1, 0.0}), Eigen::Vector3d(1.0, 2.0, 3.0));
  w.problem.poses.push_back({lonely, false});
  const BundleProblem before = w.problem;
  const BundleResult result = bundle_adjust(w.problem, kTestK);
  EXPECT_LT(result.final_cost, 0.2 * result.initial_cost);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(w.problem.poses[i].cam_from_world.translation(),
              before.poses[i].cam_from_world.translation());
    EXPECT_EQ(w.problem.poses[i].cam_from_world.quaternion().coeffs(),
              before.poses[i].cam_from_world.quaternion().coeffs());
  }
  EXPECT_LT(translation_distance(w.problem.poses.back().cam_from_world, lonely), 1e-12);
}

// Every pose fixed: the reduced system is empty and only the points move (triangulation).
TEST(DenseSchur, WithEveryPoseFixedRefinesThePointsAlone) {
  Window w = make_window({.poses = 6, .fixed = 6, .seed = 6});
  BundleProblem ceres = w.problem;
  BundleOptions ceres_options;
  ceres_options.own_dense_solver = false;
  const BundleResult ours = bundle_adjust(w.problem, kTestK);
  const BundleResult theirs = bundle_adjust(ceres, kTestK, ceres_options);
  EXPECT_LT(ours.final_cost, 0.5 * ours.initial_cost);
  EXPECT_NEAR(ours.final_cost, theirs.final_cost, 1e-10 * theirs.final_cost);
  for (std::size_t j = 0; j < w.problem.points.size(); ++j)
    EXPECT_LT((w.problem.points[j] - ceres.points[j]).norm(), 1e-8) << j;
}

TEST(DenseSchur, StopsBeforeTheFirstStepWhenAborted) {
  Window w = make_window({.poses = 6, .seed = 4});
  const BundleProblem before = w.problem;
  std::vector<double> pose_params(7 * w.problem.poses.size());
  for (std::size_t i = 0; i < w.problem.poses.size(); ++i)
    pose_to_array(w.problem.poses[i].cam_from_world, &pose_params[7 * i]);
  const std::vector<std::uint8_t> skip(w.problem.observations.size(), 0);
  double readout = 0.0;
  const std::atomic<bool> abort{true};
  const DenseSchurStats stats =
      dense_schur_solve(w.problem, pose_params, readout, kTestK, skip, DenseSchurPass{}, &abort);
  EXPECT_EQ(stats.iterations, 1);  // the evaluation at the start only
  EXPECT_EQ(stats.final_cost, stats.initial_cost);
  EXPECT_EQ(w.problem.points, before.points);
  // Not raised: it runs, and every observation skipped leaves nothing to solve.
  const std::atomic<bool> go{false};
  EXPECT_GT(dense_schur_solve(w.problem, pose_params, readout, kTestK, skip, DenseSchurPass{}, &go)
                .iterations,
            2);
  const std::vector<std::uint8_t> all(w.problem.observations.size(), 1);
  EXPECT_EQ(dense_schur_solve(w.problem, pose_params, readout, kTestK, all, DenseSchurPass{}, &go)
                .iterations,
            0);
}

// Problems with inertial terms stay with Ceres.
TEST(DenseSchur, AppliesToReprojectionsOnly) {
  BundleProblem problem;
  EXPECT_TRUE(dense_schur_applies(problem));
  problem.gravity.emplace_back();
  EXPECT_FALSE(dense_schur_applies(problem));
  problem.gravity.clear();
  problem.gyro.emplace_back();
  EXPECT_FALSE(dense_schur_applies(problem));
}

}  // namespace
}  // namespace coloc::slam::optim
