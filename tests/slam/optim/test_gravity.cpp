// The gravity residual of the global BA (optim::GravityCost): its Jacobians against numerical
// ones, and a walk around a square whose tilt drifted: gravity measured by a biased
// accelerometer takes the drift out, which the same BA without it leaves.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "slam/optim/bundle_adjustment.hpp"
#include "slam/optim/gravity_cost.hpp"
#include "tests/slam/optim/square_walk.hpp"

namespace coloc::slam::optim {
namespace {

const Intrinsics kK{520.0, 515.0, 320.0, 240.0, 40.0};

TEST(Gravity, CostJacobiansMatchNumericalDerivatives) {
  double pose[7];
  pose_to_array(SE3(SO3::exp({0.3, -0.5, 0.2}), Eigen::Vector3d(0.3, -0.1, 0.2)), pose);
  double up[3] = {0.1, -0.2, 0.97};
  double bias[3] = {0.05, -0.03, 0.02};
  const GravityCost cost({0.5, -9.6, 1.2}, {0.2, 0.1, -0.3}, 9.81, 0.02);
  double r0[3], j0[21], j1[9], j2[9];
  double* jac[3] = {j0, j1, j2};
  const double* params[3] = {pose, up, bias};
  ASSERT_TRUE(cost.Evaluate(params, r0, jac));
  const double h = 1e-6;
  auto numeric = [&](const double* const* p, int row) {
    double r[3];
    EXPECT_TRUE(cost.Evaluate(p, r, nullptr));
    return r[row];
  };
  PoseManifold manifold;
  for (int k = 0; k < 6; ++k) {  // the pose through its manifold
    double delta[6] = {0, 0, 0, 0, 0, 0}, xp[7], xm[7];
    delta[k] = h;
    manifold.Plus(pose, delta, xp);
    delta[k] = -h;
    manifold.Plus(pose, delta, xm);
    const double* pp[3] = {xp, up, bias};
    const double* pm[3] = {xm, up, bias};
    for (int row = 0; row < 3; ++row)
      EXPECT_NEAR(j0[row * 7 + k], (numeric(pp, row) - numeric(pm, row)) / (2 * h), 1e-3)
          << row << "," << k;
  }
  for (int b = 1; b <= 2; ++b) {  // up and bias, plain vectors
    for (int k = 0; k < 3; ++k) {
      double p[3], m[3];
      const double* src = b == 1 ? up : bias;
      std::copy(src, src + 3, p);
      std::copy(src, src + 3, m);
      p[k] += h;
      m[k] -= h;
      const double* pp[3] = {pose, b == 1 ? p : up, b == 2 ? p : bias};
      const double* pm[3] = {pose, b == 1 ? m : up, b == 2 ? m : bias};
      const double* j = b == 1 ? j1 : j2;
      for (int row = 0; row < 3; ++row)
        EXPECT_NEAR(j[row * 3 + k], (numeric(pp, row) - numeric(pm, row)) / (2 * h), 1e-3)
            << b << ":" << row << "," << k;
    }
  }
}

double tilt_error(const SE3& cam_from_world, const Eigen::Vector3d& up_world,
                  const SE3& true_world_from_cam) {
  const Eigen::Vector3d up_cam = cam_from_world.rotation() * up_world;
  const Eigen::Vector3d true_up_cam =
      true_world_from_cam.rotation().transpose() * Eigen::Vector3d::UnitZ();
  return std::acos(std::clamp(up_cam.normalized().dot(true_up_cam), -1.0, 1.0));
}

TEST(Gravity, BundleAdjustmentTakesTheTiltDriftOut) {
  const int n = 40;
  const std::vector<SE3> truth = square_walk(n);
  // Tracking's result: each keyframe tilted a little more than the one before, about the
  // walking direction and across it (a random walk of 1 mrad per keyframe), positions along.
  std::mt19937 rng(3);
  std::normal_distribution<double> step(0.0, 0.001);
  std::vector<SE3> drifted{truth[0]};
  Eigen::Vector3d tilt = Eigen::Vector3d::Zero();
  for (int i = 1; i < n; ++i) {
    tilt += Eigen::Vector3d(step(rng), step(rng), 0.0);
    drifted.push_back(SE3(SO3::exp(tilt), Eigen::Vector3d::Zero()) *
                      truth[static_cast<std::size_t>(i)]);
  }
  BundleProblem problem;
  for (int i = 0; i < n; ++i)
    problem.poses.push_back({drifted[static_cast<std::size_t>(i)].inverse(), i == 0});
  // Points ahead of each keyframe, placed by its drifted pose (as tracking made them) and seen
  // by it and the next two.
  std::uniform_real_distribution<double> xy(-1.0, 1.0), depth(2.0, 4.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 30; ++j) {
      const Eigen::Vector3d in_cam(xy(rng), xy(rng), depth(rng));
      const Eigen::Vector3d world = drifted[static_cast<std::size_t>(i)] * in_cam;
      const auto point = static_cast<std::uint32_t>(problem.points.size());
      problem.points.push_back(world);
      for (int k = i; k < std::min(n, i + 3); ++k) {
        const Eigen::Vector3d pc = drifted[static_cast<std::size_t>(k)].inverse() * world;
        if (pc.z() < 0.5) continue;
        BundleProblem::Observation o;
        o.pose = static_cast<std::uint32_t>(k);
        o.point = point;
        o.pixel = {kK.fx * pc.x() / pc.z() + kK.cx, kK.fy * pc.y() / pc.z() + kK.cy};
        o.u_right = o.pixel.x() - kK.bf / pc.z();
        problem.observations.push_back(o);
      }
    }
  }
  const Eigen::Vector3d bias(0.05, -0.05, 0.03);  // m/s^2, camera frame
  BundleProblem with_gravity = problem;
  for (int i = 0; i < n; ++i) {
    BundleProblem::Gravity g;
    g.pose = static_cast<std::uint32_t>(i);
    // At rest the accelerometer reads g upwards (plus its bias).
    g.specific_force_cam = truth[static_cast<std::size_t>(i)].rotation().transpose() *
                               Eigen::Vector3d(0.0, 0.0, 9.81) +
                           bias;
    with_gravity.gravity.push_back(g);
  }
  const BundleResult vision = bundle_adjust(problem, kK);
  const BundleResult result = bundle_adjust(with_gravity, kK);
  EXPECT_NEAR(result.up_world.norm(), 1.0, 1e-9);
  EXPECT_LT((result.accel_bias - bias).norm(), 0.01) << result.accel_bias.transpose();
  double before = 0.0, vision_only = 0.0, after = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    before = std::max(before, tilt_error(drifted[i].inverse(), Eigen::Vector3d::UnitZ(), truth[i]));
    vision_only = std::max(vision_only, tilt_error(problem.poses[i].cam_from_world,
                                                   Eigen::Vector3d::UnitZ(), truth[i]));
    after = std::max(after,
                     tilt_error(with_gravity.poses[i].cam_from_world, result.up_world, truth[i]));
  }
  EXPECT_GT(before, 0.004);              // the drift is there
  EXPECT_GT(vision_only, 0.8 * before);  // and vision alone keeps it
  EXPECT_LT(after, 0.3 * before) << before << " -> " << after;
  EXPECT_TRUE(vision.up_world.isZero());  // no gravity, no estimate
}

}  // namespace
}  // namespace coloc::slam::optim
