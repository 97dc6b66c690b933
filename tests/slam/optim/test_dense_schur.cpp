// Our dense-Schur Levenberg-Marquardt against Ceres on the same bundle problems: the optimum,
// the outliers it flags, the rolling-shutter readout, fixed and unobserved poses, degenerate
// points, and the abort flag.
#include <gtest/gtest.h>

#include <random>

#include "slam/optim/bundle_adjustment.hpp"
#include "slam/optim/dense_schur_lm.hpp"

namespace coloc::slam::optim {
namespace {

const Intrinsics kK{520.0, 515.0, 320.0, 240.0, 40.0};

struct Window {
  BundleProblem problem;
  std::vector<SE3> truth;
};

// A window of `poses` keyframes walking and turning past 400 points, the first two fixed.
// Observations are stereo-like or monocular in turn, 0.5 px of noise, one in forty off by
// 20-40 px (wrong matches), each with its row's rolling-shutter shear; a few points are seen
// once only, monocularly (their depth is unobservable: the damping must hold them).
Window make_window(int poses, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_real_distribution<double> xy(-2.0, 2.0), z(2.0, 6.0), wrong(20.0, 40.0);
  std::bernoulli_distribution sees(0.7), outlier(0.025), flip(0.5);
  Window w;
  for (int i = 0; i < poses; ++i) {
    const SE3 truth(SO3::exp({0.01 * i, 0.05 * i, -0.01 * i}),
                    Eigen::Vector3d(-0.12 * i, 0.02 * i, 0.01 * i));
    w.truth.push_back(truth);
    const Vector6d off = (Vector6d() << 0.01 * noise(rng), 0.01 * noise(rng), 0.01 * noise(rng),
                          0.004 * noise(rng), 0.004 * noise(rng), 0.004 * noise(rng))
                             .finished();
    w.problem.poses.push_back({i < 2 ? truth : SE3::exp(off) * truth, i < 2});
  }
  for (std::uint32_t j = 0; j < 400; ++j) {
    const Eigen::Vector3d world(xy(rng), xy(rng), z(rng));
    w.problem.points.push_back(world + 0.02 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    const bool once = j % 50 == 0;
    for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(poses); ++i) {
      if (once ? i != 3 : !sees(rng)) continue;
      const Eigen::Vector3d pc = w.truth[i] * world;
      BundleProblem::Observation o;
      o.pose = i;
      o.point = j;
      o.pixel = {kK.fx * pc.x() / pc.z() + kK.cx + noise(rng),
                 kK.fy * pc.y() / pc.z() + kK.cy + noise(rng)};
      if (outlier(rng)) o.pixel.x() += flip(rng) ? wrong(rng) : -wrong(rng);
      o.u_right = (once || (i + j) % 3 == 0) ? -1.0 : o.pixel.x() - kK.bf / pc.z();
      o.inv_sigma2 = (j % 4 == 0) ? 1.0 / 1.44 : 1.0;  // a coarser pyramid level
      o.shear = Eigen::Vector3d(0.3, -0.5, 0.1) * ((o.pixel.y() - 240.0) / 480.0);
      w.problem.observations.push_back(o);
    }
  }
  return w;
}

BundleOptions converging() {
  BundleOptions options;
  options.iterations_robust = 30;
  options.iterations_refine = 30;
  return options;
}

TEST(DenseSchur, ReachesCeresOptimumAndFlagsTheSameOutliers) {
  for (const bool readout : {false, true}) {
    Window w = make_window(12, 11);
    w.problem.readout.estimate = readout;
    w.problem.readout.prior_sigma = 0.005;
    BundleProblem ceres = w.problem;
    BundleOptions ceres_options = converging();
    ceres_options.own_dense_solver = false;
    const BundleResult ours = bundle_adjust(w.problem, kK, converging());
    const BundleResult theirs = bundle_adjust(ceres, kK, ceres_options);
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
  Window w = make_window(6, 3);
  // One free pose more that no observation reaches: it is no unknown of this solve.
  const SE3 lonely(SO3::exp({0.2, 0.1, 0.0}), Eigen::Vector3d(1.0, 2.0, 3.0));
  w.problem.poses.push_back({lonely, false});
  const BundleProblem before = w.problem;
  const BundleResult result = bundle_adjust(w.problem, kK);
  EXPECT_LT(result.final_cost, 0.2 * result.initial_cost);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(w.problem.poses[i].cam_from_world.translation(),
              before.poses[i].cam_from_world.translation());
    EXPECT_EQ(w.problem.poses[i].cam_from_world.quaternion().coeffs(),
              before.poses[i].cam_from_world.quaternion().coeffs());
  }
  EXPECT_LT(translation_distance(w.problem.poses.back().cam_from_world, lonely), 1e-12);
}

TEST(DenseSchur, StopsBeforeTheFirstStepWhenAborted) {
  Window w = make_window(6, 4);
  const BundleProblem before = w.problem;
  std::vector<double> pose_params(7 * w.problem.poses.size());
  for (std::size_t i = 0; i < w.problem.poses.size(); ++i)
    pose_to_array(w.problem.poses[i].cam_from_world, &pose_params[7 * i]);
  const std::vector<std::uint8_t> skip(w.problem.observations.size(), 0);
  double readout = 0.0;
  const std::atomic<bool> abort{true};
  const DenseSchurStats stats =
      dense_schur_solve(w.problem, pose_params, readout, kK, skip, DenseSchurPass{}, &abort);
  EXPECT_EQ(stats.iterations, 1);  // the evaluation at the start only
  EXPECT_EQ(stats.final_cost, stats.initial_cost);
  EXPECT_EQ(w.problem.points, before.points);
  // Not raised: it runs, and every observation skipped leaves nothing to solve.
  const std::atomic<bool> go{false};
  EXPECT_GT(dense_schur_solve(w.problem, pose_params, readout, kK, skip, DenseSchurPass{}, &go)
                .iterations,
            2);
  const std::vector<std::uint8_t> all(w.problem.observations.size(), 1);
  EXPECT_EQ(
      dense_schur_solve(w.problem, pose_params, readout, kK, all, DenseSchurPass{}, &go).iterations,
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
