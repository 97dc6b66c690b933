// Analytic Jacobians against numerical ones, the pose-only optimizer with outliers and with the
// motion model's centre prior, local
// bundle adjustment on a noisy synthetic window, and the rolling-shutter readout estimated by it.
#include <gtest/gtest.h>

#include <random>

#include "slam/core/error.hpp"
#include "slam/optim/bundle_adjustment.hpp"
#include "slam/optim/pose_optimizer.hpp"
#include "slam/optim/reprojection.hpp"
#include "tests/slam/optim/bundle_window.hpp"

namespace coloc::slam::optim {
namespace {

SE3 some_pose() {
  return SE3(SO3::exp({0.1, -0.2, 0.05}), Eigen::Vector3d(0.3, -0.1, 0.2));
}

TEST(Optim, CostJacobiansMatchNumericalDerivativesOnTheManifold) {
  const SE3 pose = some_pose();
  const Eigen::Vector3d world(0.4, -0.3, 2.5);
  double x[7];
  pose_to_array(pose, x);
  double pt[3] = {world.x(), world.y(), world.z()};
  const StereoReprojectionCost stereo(kTestK, {300.0, 250.0, 290.0}, 1.0 / 1.2);
  const MonoReprojectionCost mono(kTestK, {300.0, 250.0}, 1.0);
  PoseManifold manifold;
  auto check = [&](const ceres::CostFunction& cost, int rows) {
    const double* params[2] = {x, pt};
    std::vector<double> r0(static_cast<std::size_t>(rows)), j0(static_cast<std::size_t>(rows * 7)),
        j1(static_cast<std::size_t>(rows * 3));
    double* jac[2] = {j0.data(), j1.data()};
    ASSERT_TRUE(cost.Evaluate(params, r0.data(), jac));
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {  // pose: through the manifold's Plus
      double delta[6] = {0, 0, 0, 0, 0, 0};
      double xp[7], xm[7];
      delta[k] = h;
      manifold.Plus(x, delta, xp);
      delta[k] = -h;
      manifold.Plus(x, delta, xm);
      std::vector<double> rp(r0.size()), rm(r0.size());
      const double* pp[2] = {xp, pt};
      const double* pm[2] = {xm, pt};
      cost.Evaluate(pp, rp.data(), nullptr);
      cost.Evaluate(pm, rm.data(), nullptr);
      for (int r = 0; r < rows; ++r) {
        const double numeric =
            (rp[static_cast<std::size_t>(r)] - rm[static_cast<std::size_t>(r)]) / (2 * h);
        EXPECT_NEAR(j0[static_cast<std::size_t>(r * 7 + k)], numeric,
                    1e-4 * (1.0 + std::abs(numeric)))
            << "pose col " << k;
      }
    }
    for (int k = 0; k < 3; ++k) {  // point
      double pp3[3] = {pt[0], pt[1], pt[2]}, pm3[3] = {pt[0], pt[1], pt[2]};
      pp3[k] += h;
      pm3[k] -= h;
      std::vector<double> rp(r0.size()), rm(r0.size());
      const double* pp[2] = {x, pp3};
      const double* pm[2] = {x, pm3};
      cost.Evaluate(pp, rp.data(), nullptr);
      cost.Evaluate(pm, rm.data(), nullptr);
      for (int r = 0; r < rows; ++r) {
        const double numeric =
            (rp[static_cast<std::size_t>(r)] - rm[static_cast<std::size_t>(r)]) / (2 * h);
        EXPECT_NEAR(j1[static_cast<std::size_t>(r * 3 + k)], numeric,
                    1e-4 * (1.0 + std::abs(numeric)))
            << "point col " << k;
      }
    }
  };
  check(stereo, 3);
  check(mono, 2);
  // Minus inverts Plus.
  const double delta[6] = {0.01, -0.02, 0.03, 0.004, -0.005, 0.006};
  double y[7], back[6];
  manifold.Plus(x, delta, y);
  manifold.Minus(y, x, back);
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(back[k], delta[k], 1e-12);
}

// Points in front of `pose`, observed with noise; `outliers` of them grossly wrong.
std::vector<PoseObservation> observe(const SE3& pose, int n, int outliers, std::mt19937& rng) {
  std::uniform_real_distribution<double> ux(20, 620), uy(20, 460), depth(0.8, 4.0);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::vector<PoseObservation> obs;
  for (int i = 0; i < n; ++i) {
    const double z = depth(rng);
    const Eigen::Vector2d uv(ux(rng), uy(rng));
    const Eigen::Vector3d pc((uv.x() - kTestK.cx) * z / kTestK.fx,
                             (uv.y() - kTestK.cy) * z / kTestK.fy, z);
    PoseObservation o;
    o.world = pose.inverse() * pc;
    o.pixel = uv + Eigen::Vector2d(noise(rng), noise(rng));
    o.u_right = (i % 3 == 0) ? -1.0 : uv.x() - kTestK.bf / z + noise(rng);
    if (i < outliers) o.pixel += Eigen::Vector2d(40.0, -30.0);
    obs.push_back(o);
  }
  return obs;
}

TEST(Optim, PoseOptimizationRecoversPoseAndFlagsOutliers) {
  std::mt19937 rng(3);
  const SE3 truth = some_pose();
  const auto obs = observe(truth, 200, 30, rng);
  const SE3 start =
      SE3::exp((Vector6d() << 0.05, -0.03, 0.04, 0.03, -0.02, 0.02).finished()) * truth;
  const auto r = optimize_pose(start, obs, kTestK);
  EXPECT_LT(translation_distance(r.cam_from_world, truth), 0.005);
  EXPECT_LT(rotation_distance(r.cam_from_world, truth), 0.002);
  int flagged = 0;
  for (int i = 0; i < 30; ++i)
    flagged += r.outlier[static_cast<std::size_t>(i)];
  EXPECT_EQ(flagged, 30);
  EXPECT_GE(r.inliers, 150);
  EXPECT_THROW(optimize_pose(start, obs, kTestK, {.rounds = 0}), Error);
}

Eigen::Vector3d centre(const SE3& cam_from_world) {
  return cam_from_world.inverse().translation();
}

// A blurred frame: few far keypoints near the image centre, 3 px off, where a turn and a
// sideways step look alike. The prior at the predicted centre keeps the step out.
TEST(Optim, CentrePriorHoldsTheCentreOfAWeaklyObservedFrame) {
  const SE3 truth = some_pose();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(260, 380), v(190, 290), depth(3.0, 4.0);
  std::normal_distribution<double> noise(0.0, 3.0);
  std::vector<PoseObservation> obs;
  for (int i = 0; i < 12; ++i) {
    const double z = depth(rng);
    const Eigen::Vector2d uv(u(rng), v(rng));
    PoseObservation o;
    o.world = truth.inverse() * Eigen::Vector3d((uv.x() - kTestK.cx) * z / kTestK.fx,
                                                (uv.y() - kTestK.cy) * z / kTestK.fy, z);
    o.pixel = uv + Eigen::Vector2d(noise(rng), noise(rng));
    obs.push_back(o);
  }
  const CentrePrior prior{.world_centre = centre(truth), .sigma_m = 0.01};
  const auto free = optimize_pose(truth, obs, kTestK);
  const auto held = optimize_pose(truth, obs, kTestK, {}, &prior);
  const double free_m = (centre(free.cam_from_world) - centre(truth)).norm();
  const double held_m = (centre(held.cam_from_world) - centre(truth)).norm();
  EXPECT_GT(free_m, 0.03) << "the frame alone does not fix its centre";
  EXPECT_LT(held_m, 0.01);
  const CentrePrior no_sigma{.sigma_m = 0.0};
  EXPECT_THROW(optimize_pose(truth, obs, kTestK, {}, &no_sigma), Error);
}

// A sharp frame's hundreds of inliers outweigh a prior 5 cm off: the prediction of a camera
// that did accelerate does not bend its pose.
TEST(Optim, CentrePriorLeavesAWellObservedFrameToItsPoints) {
  std::mt19937 rng(3);
  const SE3 truth = some_pose();
  const auto obs = observe(truth, 200, 0, rng);
  const CentrePrior prior{.world_centre = centre(truth) + Eigen::Vector3d(0.05, 0.0, 0.0),
                          .sigma_m = 0.01};
  const auto free = optimize_pose(truth, obs, kTestK);
  const auto held = optimize_pose(truth, obs, kTestK, {}, &prior);
  EXPECT_LT((centre(held.cam_from_world) - centre(free.cam_from_world)).norm(), 0.002);
  EXPECT_LT(rotation_distance(held.cam_from_world, free.cam_from_world), 0.001);
}

TEST(Optim, LocalBundleAdjustmentReducesPoseAndPointErrors) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  BundleProblem problem;
  std::vector<SE3> truth;
  for (int i = 0; i < 5; ++i) {
    truth.push_back(SE3(SO3::exp({0.0, 0.03 * i, 0.0}), Eigen::Vector3d(-0.1 * i, 0.0, 0.0)));
  }
  std::vector<Eigen::Vector3d> points;
  std::uniform_real_distribution<double> xy(-1.5, 1.5), z(2.0, 4.0);
  for (int j = 0; j < 150; ++j)
    points.emplace_back(xy(rng), xy(rng), z(rng));
  for (int i = 0; i < 5; ++i) {
    SE3 start = truth[static_cast<std::size_t>(i)];
    if (i >= 2)
      start = SE3::exp((Vector6d() << 0.02, -0.01, 0.02, 0.01, 0.01, -0.01).finished()) * start;
    problem.poses.push_back({start, i < 2});  // two fixed poses fix the gauge
  }
  double initial_err = 0.0;
  for (std::size_t j = 0; j < points.size(); ++j) {
    problem.points.push_back(points[j] +
                             0.03 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    initial_err += (problem.points.back() - points[j]).norm();
    for (std::uint32_t i = 0; i < 5; ++i) {
      const Eigen::Vector3d pc = truth[i] * points[j];
      BundleProblem::Observation o;
      o.pose = i;
      o.point = static_cast<std::uint32_t>(j);
      o.pixel = {kTestK.fx * pc.x() / pc.z() + kTestK.cx + 0.3 * noise(rng),
                 kTestK.fy * pc.y() / pc.z() + kTestK.cy + 0.3 * noise(rng)};
      o.u_right = (j % 2) ? -1.0 : o.pixel.x() - kTestK.bf / pc.z();
      problem.observations.push_back(o);
    }
  }
  BundleProblem sparse = problem, dense = problem;
  const auto result = bundle_adjust(problem, kTestK);  // 3 free poses: our dense-Schur LM
  EXPECT_FALSE(result.aborted);
  EXPECT_LT(result.final_cost, result.initial_cost);
  // Ceres' dense and sparse factorizations (the latter for large problems) and our dense-Schur
  // LM take the same steps to the same optimum.
  BundleOptions dense_options, sparse_options;
  dense_options.own_dense_solver = false;
  sparse_options.dense_schur_max_poses = 0;
  const auto dense_result = bundle_adjust(dense, kTestK, dense_options);
  const auto sparse_result = bundle_adjust(sparse, kTestK, sparse_options);
  EXPECT_NEAR(sparse_result.final_cost, dense_result.final_cost, 1e-9 * result.final_cost);
  EXPECT_NEAR(result.final_cost, dense_result.final_cost, 1e-9 * result.final_cost);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_LT(translation_distance(sparse.poses[i].cam_from_world, dense.poses[i].cam_from_world),
              1e-9);
    EXPECT_LT(translation_distance(dense.poses[i].cam_from_world, problem.poses[i].cam_from_world),
              1e-9);
  }
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_LT(translation_distance(problem.poses[i].cam_from_world, truth[i]), 0.005) << i;
  }
  EXPECT_TRUE(problem.poses[0].cam_from_world.translation().isApprox(truth[0].translation()));
  double err = 0.0;
  for (std::size_t j = 0; j < points.size(); ++j)
    err += (problem.points[j] - points[j]).norm();
  EXPECT_LT(err, 0.5 * initial_err);  // what is left is the measurement noise
  // A raised abort flag stops the solver at once.
  std::atomic<bool> abort{true};
  const auto aborted = bundle_adjust(problem, kTestK, {}, &abort);
  EXPECT_TRUE(aborted.aborted);
}

// The readout parameter: its column against a numerical derivative; the pose and point columns
// are the plain cost's at the shifted observation (checked numerically above).
TEST(Optim, ShutterCostJacobianOfTheReadoutMatchesNumericalDerivative) {
  double x[7];
  pose_to_array(some_pose(), x);
  double pt[3] = {0.4, -0.3, 2.5};
  const Eigen::Vector3d obs(300.0, 250.0, 290.0), shear(0.6, -1.1, 0.4);
  const ShutterReprojectionCost<3> cost(kTestK, obs, shear, 1.0 / 1.2);
  const double delta = 0.004, h = 1e-7;
  auto eval = [&](double d, double* r, double** jac) {
    const double* params[3] = {x, pt, &d};
    ASSERT_TRUE(cost.Evaluate(params, r, jac));
  };
  double r0[3], rp[3], rm[3], j0[21], j1[9], j2[3];
  double* jac[3] = {j0, j1, j2};
  eval(delta, r0, jac);
  eval(delta + h, rp, nullptr);
  eval(delta - h, rm, nullptr);
  for (int r = 0; r < 3; ++r)
    EXPECT_NEAR(j2[r], (rp[r] - rm[r]) / (2 * h), 1e-4 * (1.0 + std::abs(j2[r]))) << r;
  EXPECT_GT(std::abs(j2[0]) + std::abs(j2[1]), 1.0);  // the shear does move the pixel
  const Eigen::Vector3d shifted = shutter_shifted(kTestK, obs, shear, delta, nullptr);
  const StereoReprojectionCost plain(kTestK, shifted, 1.0 / 1.2);
  double pr[3], pj0[21], pj1[9];
  double* pjac[2] = {pj0, pj1};
  const double* pparams[2] = {x, pt};
  ASSERT_TRUE(plain.Evaluate(pparams, pr, pjac));
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(r0[i], pr[i], 1e-9);
  for (int i = 0; i < 21; ++i)
    EXPECT_NEAR(j0[i], pj0[i], 1e-9);
  for (int i = 0; i < 9; ++i)
    EXPECT_NEAR(j1[i], pj1[i], 1e-9);
}

// A rolling-shutter window: each keyframe turns at its own rate while its rows are read out over
// 20 ms. Observations compensated with a readout of 0 (what a camera without a known readout
// gives) carry each row's shear; the BA with the readout as an unknown finds the 20 ms, which a
// BA without it cannot express.
TEST(Optim, BundleAdjustmentEstimatesTheRollingShutterReadout) {
  constexpr double kReadout = 0.02, kRows = 480.0;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> xy(-1.5, 1.5), z(2.0, 4.0);
  std::vector<SE3> truth;
  std::vector<Eigen::Vector3d>
      rates;  // rad/s, camera frame: turns that differ from keyframe to keyframe
  for (int i = 0; i < 8; ++i) {
    truth.push_back(
        SE3(SO3::exp({0.02 * i, 0.04 * i, 0.0}), Eigen::Vector3d(-0.08 * i, 0.02 * i, 0.0)));
    rates.emplace_back(1.5 * std::sin(1.3 * i), 2.0 * std::cos(0.9 * i), 0.8 * std::sin(2.1 * i));
  }
  BundleProblem problem;
  for (int i = 0; i < 8; ++i)
    problem.poses.push_back({truth[static_cast<std::size_t>(i)], i < 2});
  for (int j = 0; j < 200; ++j) {
    const Eigen::Vector3d world(xy(rng), xy(rng), z(rng));
    problem.points.push_back(world);
    for (std::uint32_t i = 0; i < 8; ++i) {
      // The row that sees the point: solved by fixed-point iteration (the pose depends on it).
      const Eigen::Vector3d pc = truth[i] * world;
      Eigen::Vector3d raw = pc;
      Eigen::Vector3d shear = Eigen::Vector3d::Zero();
      for (int it = 0; it < 5; ++it) {
        const double v = kTestK.fy * raw.y() / raw.z() + kTestK.cy;
        shear = rates[i] * ((v - 0.5 * (kRows - 1)) / kRows);
        raw = SO3::exp(-shear * kReadout) * pc;  // compensation turns it back by +shear * readout
      }
      BundleProblem::Observation o;
      o.pose = i;
      o.point = static_cast<std::uint32_t>(j);
      o.pixel = {kTestK.fx * raw.x() / raw.z() + kTestK.cx + noise(rng),
                 kTestK.fy * raw.y() / raw.z() + kTestK.cy + noise(rng)};
      o.u_right = o.pixel.x() - kTestK.bf / pc.z();
      o.shear = shear;
      problem.observations.push_back(o);
    }
  }
  BundleOptions options;
  options.iterations_robust = 10;
  options.iterations_refine = 10;
  BundleProblem fixed = problem;
  const BundleResult without = bundle_adjust(fixed, kTestK, options);
  EXPECT_EQ(without.readout_change, 0.0);
  problem.readout.estimate = true;
  // A prior far tighter than the data holds it; the bounds hold it within [min, max].
  BundleProblem held = problem;
  held.readout.prior_sigma = 1e-6;
  EXPECT_LT(std::abs(bundle_adjust(held, kTestK, options).readout_change), 0.001);
  BundleProblem bounded = problem;
  bounded.readout.max = 0.01;
  EXPECT_LE(bundle_adjust(bounded, kTestK, options).readout_change, 0.01 + 1e-9);
  problem.readout.prior_sigma = 0.05;  // no say: the data alone
  const BundleResult with = bundle_adjust(problem, kTestK, options);
  EXPECT_NEAR(with.readout_change, kReadout, 0.002);
  EXPECT_LT(with.final_cost, 0.5 * without.final_cost);
  for (std::size_t i = 2; i < 8; ++i) {
    EXPECT_LT(translation_distance(problem.poses[i].cam_from_world, truth[i]), 0.003) << i;
  }
}

}  // namespace
}  // namespace coloc::slam::optim
