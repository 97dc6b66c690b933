#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "slam/core/so3.hpp"
#include "tests/slam/core/numeric.hpp"

namespace coloc {
namespace {

using testing::numeric_jacobian;

std::vector<Eigen::Vector3d> test_rotation_vectors() {
  std::vector<Eigen::Vector3d> out;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Angles from 0 through tiny values up to (just below and exactly) pi.
  for (double angle :
       {0.0, 1e-12, 1e-8, 1e-5, 1e-3, 0.1, 0.5, 1.0, 2.0, 3.0, M_PI - 1e-6, M_PI - 1e-9, M_PI}) {
    for (int k = 0; k < 5; ++k) {
      Eigen::Vector3d axis(u(rng), u(rng), u(rng));
      out.push_back(axis.normalized() * angle);
    }
  }
  return out;
}

TEST(SO3, ExpLogRoundTripUpToPi) {
  for (const auto& w : test_rotation_vectors()) {
    const SO3 r = SO3::exp(w);
    const Eigen::Vector3d w2 = r.log();
    const double angle = w.norm();
    if (angle < M_PI - 1e-6) {
      EXPECT_LT((w2 - w).norm(), 1e-9 * std::max(1.0, angle)) << w.transpose();
    } else {
      // At pi, w and -w are the same rotation.
      EXPECT_LT(std::min((w2 - w).norm(), (w2 + w).norm()), 1e-6) << w.transpose();
    }
    EXPECT_LT((SO3::exp(w2).matrix() - r.matrix()).norm(), 1e-12);
    EXPECT_NEAR(r.angle(), std::min(angle, M_PI), 1e-9);
  }
}

TEST(SO3, ExpMatchesRodrigues) {
  for (const auto& w : test_rotation_vectors()) {
    const double t = w.norm();
    Eigen::Matrix3d expected = Eigen::Matrix3d::Identity();
    if (t > 0) {
      const Eigen::Matrix3d k = SO3::hat(w / t);
      expected += std::sin(t) * k + (1 - std::cos(t)) * k * k;
    }
    EXPECT_LT((SO3::exp(w).matrix() - expected).norm(), 1e-12);
  }
}

TEST(SO3, TinyAnglesKeepFullRelativePrecision) {
  const Eigen::Vector3d w(3e-13, -1e-13, 2e-13);
  EXPECT_LT((SO3::exp(w).log() - w).norm(), 1e-25);
}

TEST(SO3, HatVeeComposeInverse) {
  const Eigen::Vector3d v(0.3, -0.2, 0.9);
  EXPECT_TRUE(SO3::vee(SO3::hat(v)).isApprox(v));
  EXPECT_TRUE((SO3::hat(v) * Eigen::Vector3d(1, 2, 3)).isApprox(v.cross(Eigen::Vector3d(1, 2, 3))));
  const SO3 a = SO3::exp({0.1, 0.2, 0.3});
  const SO3 b = SO3::exp({-0.5, 0.4, 1.3});
  EXPECT_LT(((a * b).matrix() - a.matrix() * b.matrix()).norm(), 1e-14);
  EXPECT_LT(((a * a.inverse()).matrix() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  const Eigen::Vector3d p(1, -2, 0.5);
  EXPECT_LT((a * p - a.matrix() * p).norm(), 1e-14);
}

TEST(SO3, FromMatrixProjectsOntoRotations) {
  const SO3 r = SO3::exp({0.4, -1.0, 2.0});
  Eigen::Matrix3d noisy = r.matrix();
  noisy(0, 1) += 1e-4;
  const SO3 projected = SO3::from_matrix(noisy);
  EXPECT_LT(angular_distance(projected, r), 1e-4);
  EXPECT_NEAR(projected.matrix().determinant(), 1.0, 1e-12);
  // Rotations by exactly pi (w = 0 quaternions) survive the matrix round trip.
  const SO3 half_turn = SO3::exp(Eigen::Vector3d(0, 0, M_PI));
  EXPECT_LT(angular_distance(SO3::from_matrix(half_turn.matrix()), half_turn), 1e-12);
}

TEST(SO3, AdjointIdentity) {
  const SO3 r = SO3::exp({0.3, 0.7, -0.2});
  const Eigen::Vector3d w(0.05, -0.1, 0.2);
  EXPECT_LT(((r * SO3::exp(w) * r.inverse()).matrix() - SO3::exp(r.adjoint() * w).matrix()).norm(),
            1e-13);
}

TEST(SO3, LeftAndRightJacobiansMatchNumericDerivatives) {
  for (const auto& w : test_rotation_vectors()) {
    if (w.norm() > 3.0) continue;  // log jumps at pi; the Jacobians are checked below it
    const SO3 r = SO3::exp(w);
    // Right: log(exp(w)^-1 exp(w + d)) ~= Jr d.
    auto right = [&](const Eigen::Vector3d& d) { return (r.inverse() * SO3::exp(w + d)).log(); };
    auto left = [&](const Eigen::Vector3d& d) { return (SO3::exp(w + d) * r.inverse()).log(); };
    const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
    EXPECT_LT((numeric_jacobian<3, 3>(right, zero) - SO3::right_jacobian(w)).norm(), 1e-7);
    EXPECT_LT((numeric_jacobian<3, 3>(left, zero) - SO3::left_jacobian(w)).norm(), 1e-7);
    EXPECT_LT((SO3::left_jacobian(w) * SO3::left_jacobian_inverse(w) - Eigen::Matrix3d::Identity())
                  .norm(),
              1e-9);
    EXPECT_LT(
        (SO3::right_jacobian(w) * SO3::right_jacobian_inverse(w) - Eigen::Matrix3d::Identity())
            .norm(),
        1e-9);
  }
}

TEST(SO3, LogDerivativeIsInverseRightJacobian) {
  const Eigen::Vector3d w(0.4, -0.3, 1.1);
  const SO3 r = SO3::exp(w);
  auto f = [&](const Eigen::Vector3d& d) { return (r * SO3::exp(d)).log(); };
  EXPECT_LT(
      (numeric_jacobian<3, 3>(f, Eigen::Vector3d::Zero()) - SO3::right_jacobian_inverse(w)).norm(),
      1e-7);
}

TEST(SO3, InterpolationIsGeodesic) {
  const SO3 a = SO3::exp({0.1, 0.2, 0.3});
  const SO3 b = SO3::exp({1.0, -0.5, 0.2});
  EXPECT_LT(angular_distance(interpolate(a, b, 0.0), a), 1e-12);
  EXPECT_LT(angular_distance(interpolate(a, b, 1.0), b), 1e-12);
  const SO3 mid = interpolate(a, b, 0.5);
  EXPECT_NEAR(angular_distance(a, mid), angular_distance(mid, b), 1e-12);
  EXPECT_NEAR(angular_distance(a, mid), 0.5 * angular_distance(a, b), 1e-12);
  // Agrees with Eigen's slerp.
  EXPECT_LT(angular_distance(mid, SO3(a.quaternion().slerp(0.5, b.quaternion()))), 1e-12);
}

}  // namespace
}  // namespace coloc
