// Analytic Jacobians against numerical ones, the pose-only optimizer with outliers, and local
// bundle adjustment on a noisy synthetic window.
#include <gtest/gtest.h>

#include <random>

#include "slam/core/error.hpp"
#include "slam/optim/bundle_adjustment.hpp"
#include "slam/optim/pose_optimizer.hpp"

namespace coloc::slam::optim {
namespace {

const Intrinsics kK{520.0, 515.0, 320.0, 240.0, 40.0};

SE3 some_pose() {
  return SE3(SO3::exp({0.1, -0.2, 0.05}), Eigen::Vector3d(0.3, -0.1, 0.2));
}

TEST(Optim, CostJacobiansMatchNumericalDerivativesOnTheManifold) {
  const SE3 pose = some_pose();
  const Eigen::Vector3d world(0.4, -0.3, 2.5);
  double x[7];
  pose_to_array(pose, x);
  double pt[3] = {world.x(), world.y(), world.z()};
  const StereoReprojectionCost stereo(kK, {300.0, 250.0, 290.0}, 1.0 / 1.2);
  const MonoReprojectionCost mono(kK, {300.0, 250.0}, 1.0);
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
    const Eigen::Vector3d pc((uv.x() - kK.cx) * z / kK.fx, (uv.y() - kK.cy) * z / kK.fy, z);
    PoseObservation o;
    o.world = pose.inverse() * pc;
    o.pixel = uv + Eigen::Vector2d(noise(rng), noise(rng));
    o.u_right = (i % 3 == 0) ? -1.0 : uv.x() - kK.bf / z + noise(rng);
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
  const auto r = optimize_pose(start, obs, kK);
  EXPECT_LT(translation_distance(r.cam_from_world, truth), 0.005);
  EXPECT_LT(rotation_distance(r.cam_from_world, truth), 0.002);
  int flagged = 0;
  for (int i = 0; i < 30; ++i)
    flagged += r.outlier[static_cast<std::size_t>(i)];
  EXPECT_EQ(flagged, 30);
  EXPECT_GE(r.inliers, 150);
  EXPECT_THROW(optimize_pose(start, obs, kK, {.rounds = 0}), Error);
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
      o.pixel = {kK.fx * pc.x() / pc.z() + kK.cx + 0.3 * noise(rng),
                 kK.fy * pc.y() / pc.z() + kK.cy + 0.3 * noise(rng)};
      o.u_right = (j % 2) ? -1.0 : o.pixel.x() - kK.bf / pc.z();
      problem.observations.push_back(o);
    }
  }
  const auto result = bundle_adjust(problem, kK);
  EXPECT_FALSE(result.aborted);
  EXPECT_LT(result.final_cost, result.initial_cost);
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
  const auto aborted = bundle_adjust(problem, kK, {}, &abort);
  EXPECT_TRUE(aborted.aborted);
}

}  // namespace
}  // namespace coloc::slam::optim
