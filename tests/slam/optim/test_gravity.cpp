// The gravity residual of the global BA (optim::GravityCost): its Jacobians against numerical
// ones, and a walk around a square whose tilt drifted: gravity measured by a biased
// accelerometer takes the drift out, which the same BA without it leaves.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "slam/optim/bundle_adjustment.hpp"
#include "slam/optim/gravity_cost.hpp"
#include "tests/slam/optim/bundle_window.hpp"
#include "tests/slam/optim/square_walk.hpp"

namespace coloc::slam::optim {
namespace {

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

// A walk around a square whose tilt drifted as tracking leaves it: each keyframe tilted a little
// more than the one before (a random walk of 1 mrad per keyframe, about the walking direction and
// across it), with points placed by the drifted poses and seen exactly.
struct DriftedWalk {
  std::vector<SE3> truth;    // world_from_cam
  std::vector<SE3> drifted;  // world_from_cam
  BundleProblem problem;     // vision only

  // The accelerometer at rest on keyframe i: g upwards, plus the bias.
  BundleProblem::Gravity at_rest(std::size_t i, const Eigen::Vector3d& bias) const {
    BundleProblem::Gravity g;
    g.pose = static_cast<std::uint32_t>(i);
    g.specific_force_cam = truth[i].rotation().transpose() * Eigen::Vector3d(0.0, 0.0, 9.81) + bias;
    return g;
  }
  // The worst tilt error of the problem's poses against `up_world`.
  double worst_tilt(const BundleProblem& p, const Eigen::Vector3d& up_world) const;
};

double tilt_error(const SE3& cam_from_world, const Eigen::Vector3d& up_world,
                  const SE3& true_world_from_cam) {
  const Eigen::Vector3d up_cam = cam_from_world.rotation() * up_world;
  const Eigen::Vector3d true_up_cam =
      true_world_from_cam.rotation().transpose() * Eigen::Vector3d::UnitZ();
  return std::acos(std::clamp(up_cam.normalized().dot(true_up_cam), -1.0, 1.0));
}

double DriftedWalk::worst_tilt(const BundleProblem& p, const Eigen::Vector3d& up_world) const {
  double worst = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    worst = std::max(worst, tilt_error(p.poses[i].cam_from_world, up_world, truth[i]));
  return worst;
}

DriftedWalk drifted_walk(int n) {
  DriftedWalk w;
  w.truth = square_walk(n);
  const std::vector<SE3>& truth = w.truth;
  std::vector<SE3>& drifted = w.drifted;
  BundleProblem& problem = w.problem;
  std::mt19937 rng(3);
  std::normal_distribution<double> step(0.0, 0.001);
  drifted.push_back(truth[0]);
  Eigen::Vector3d tilt = Eigen::Vector3d::Zero();
  for (int i = 1; i < n; ++i) {
    tilt += Eigen::Vector3d(step(rng), step(rng), 0.0);
    drifted.push_back(SE3(SO3::exp(tilt), Eigen::Vector3d::Zero()) *
                      truth[static_cast<std::size_t>(i)]);
  }
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
        o.pixel = {kTestK.fx * pc.x() / pc.z() + kTestK.cx,
                   kTestK.fy * pc.y() / pc.z() + kTestK.cy};
        o.u_right = o.pixel.x() - kTestK.bf / pc.z();
        problem.observations.push_back(o);
      }
    }
  }
  return w;
}

TEST(Gravity, BundleAdjustmentTakesTheTiltDriftOut) {
  const int n = 40;
  const DriftedWalk walk = drifted_walk(n);
  const std::vector<SE3>& truth = walk.truth;
  const std::vector<SE3>& drifted = walk.drifted;
  BundleProblem problem = walk.problem;
  const Eigen::Vector3d bias(0.05, -0.05, 0.03);  // m/s^2, camera frame
  BundleProblem with_gravity = problem;
  for (std::size_t i = 0; i < truth.size(); ++i)
    with_gravity.gravity.push_back(walk.at_rest(i, bias));
  const BundleResult vision = bundle_adjust(problem, kTestK);
  const BundleResult result = bundle_adjust(with_gravity, kTestK);
  EXPECT_NEAR(result.up_world.norm(), 1.0, 1e-9);
  ASSERT_EQ(result.accel_bias.size(), 1u);
  EXPECT_LT((result.accel_bias[0] - bias).norm(), 0.01) << result.accel_bias[0].transpose();
  double before = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    before = std::max(before, tilt_error(drifted[i].inverse(), Eigen::Vector3d::UnitZ(), truth[i]));
  const double vision_only = walk.worst_tilt(problem, Eigen::Vector3d::UnitZ());
  const double after = walk.worst_tilt(with_gravity, result.up_world);
  EXPECT_GT(before, 0.004);              // the drift is there
  EXPECT_GT(vision_only, 0.8 * before);  // and vision alone keeps it
  EXPECT_LT(after, 0.3 * before) << before << " -> " << after;
  EXPECT_TRUE(vision.up_world.isZero());  // no gravity, no estimate
}

// A continued map: the walk's second half is another recording, whose accelerometer came up
// with another bias. A bias per recording (BundleProblem::Gravity::bias) finds both; one bias
// for all splits the difference and tilts both halves.
TEST(Gravity, EachRecordingHasItsOwnAccelerometerBias) {
  const DriftedWalk walk = drifted_walk(40);
  const Eigen::Vector3d bias[2] = {{0.08, -0.06, 0.03}, {-0.06, 0.05, 0.06}};  // m/s^2
  BundleProblem per_recording = walk.problem;
  BundleProblem shared = walk.problem;
  for (std::size_t i = 0; i < walk.truth.size(); ++i) {
    BundleProblem::Gravity g = walk.at_rest(i, bias[i < walk.truth.size() / 2 ? 0 : 1]);
    shared.gravity.push_back(g);
    g.bias = i < walk.truth.size() / 2 ? 0 : 1;
    per_recording.gravity.push_back(g);
  }
  const BundleResult one = bundle_adjust(shared, kTestK);
  const BundleResult two = bundle_adjust(per_recording, kTestK);
  ASSERT_EQ(two.accel_bias.size(), 2u);
  for (std::size_t r = 0; r < 2; ++r)
    EXPECT_LT((two.accel_bias[r] - bias[r]).norm(), 0.03) << two.accel_bias[r].transpose();
  const double tilt_one = walk.worst_tilt(shared, one.up_world);
  const double tilt_two = walk.worst_tilt(per_recording, two.up_world);
  EXPECT_LT(tilt_two, 0.5 * tilt_one) << tilt_one << " -> " << tilt_two;
  EXPECT_LT(two.gravity_rms, 0.5 * one.gravity_rms) << one.gravity_rms << " -> " << two.gravity_rms;
}

}  // namespace
}  // namespace coloc::slam::optim
