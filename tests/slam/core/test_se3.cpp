#include <gtest/gtest.h>

#include <random>

#include "slam/core/se3.hpp"
#include "tests/slam/core/numeric.hpp"

namespace coloc {
namespace {

using testing::numeric_jacobian;

std::vector<Vector6d> test_twists() {
  std::vector<Vector6d> out;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-9, 1e-4, 0.05, 0.3, 1.0, 2.5, M_PI - 1e-5}) {
    for (int k = 0; k < 4; ++k) {
      Vector6d xi;
      xi.head<3>() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 2.0;
      xi.tail<3>() = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * angle;
      out.push_back(xi);
    }
  }
  return out;
}

TEST(SE3, ExpLogRoundTrip) {
  for (const auto& xi : test_twists()) {
    const SE3 t = SE3::exp(xi);
    EXPECT_LT((t.log() - xi).norm(), 1e-8) << xi.transpose();
    EXPECT_LT((SE3::exp(t.log()).matrix() - t.matrix()).norm(), 1e-10);
  }
}

TEST(SE3, ExpMatchesMatrixExponentialSeries) {
  for (const auto& xi : test_twists()) {
    const Eigen::Matrix4d a = SE3::hat(xi);
    Eigen::Matrix4d sum = Eigen::Matrix4d::Identity();
    Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
    for (int k = 1; k < 40; ++k) {
      term = term * a / k;
      sum += term;
    }
    EXPECT_LT((SE3::exp(xi).matrix() - sum).norm(), 1e-10);
  }
}

TEST(SE3, ComposeInverseActAndFrameNames) {
  const SE3 world_from_cam = SE3::exp((Vector6d() << 1, 2, 3, 0.1, -0.2, 0.3).finished());
  const SE3 cam_from_marker = SE3::exp((Vector6d() << -0.5, 0.1, 2, 0.5, 0.2, -0.1).finished());
  const SE3 world_from_marker = world_from_cam * cam_from_marker;
  const Eigen::Vector3d p_marker(0.1, 0.2, 0.0);
  EXPECT_LT((world_from_marker * p_marker - world_from_cam * (cam_from_marker * p_marker)).norm(),
            1e-12);
  EXPECT_LT(
      ((world_from_cam * world_from_cam.inverse()).matrix() - Eigen::Matrix4d::Identity()).norm(),
      1e-12);
  EXPECT_LT(
      (world_from_marker.matrix() - world_from_cam.matrix() * cam_from_marker.matrix()).norm(),
      1e-12);
  EXPECT_LT((SE3::from_matrix(world_from_cam.matrix()).matrix() - world_from_cam.matrix()).norm(),
            1e-12);
  EXPECT_LT(
      (SE3::from_matrix3x4(world_from_cam.matrix3x4()).matrix() - world_from_cam.matrix()).norm(),
      1e-12);
}

TEST(SE3, Adjoint) {
  const SE3 t = SE3::exp((Vector6d() << 0.3, -1, 2, 0.4, 0.1, -0.7).finished());
  const Vector6d xi = (Vector6d() << 0.01, 0.02, -0.03, 0.05, -0.02, 0.01).finished();
  EXPECT_LT(
      ((t * SE3::exp(xi) * t.inverse()).matrix() - SE3::exp(t.adjoint() * xi).matrix()).norm(),
      1e-12);
}

TEST(SE3, JacobiansMatchNumericDerivatives) {
  for (const auto& xi : test_twists()) {
    if (xi.tail<3>().norm() > 3.0) continue;
    const SE3 t = SE3::exp(xi);
    auto right = [&](const Vector6d& d) { return (t.inverse() * SE3::exp(xi + d)).log(); };
    auto left = [&](const Vector6d& d) { return (SE3::exp(xi + d) * t.inverse()).log(); };
    const Vector6d zero = Vector6d::Zero();
    EXPECT_LT((numeric_jacobian<6, 6>(right, zero) - SE3::right_jacobian(xi)).norm(), 1e-6)
        << xi.transpose();
    EXPECT_LT((numeric_jacobian<6, 6>(left, zero) - SE3::left_jacobian(xi)).norm(), 1e-6)
        << xi.transpose();
  }
}

TEST(SE3, ActionJacobianOnPoint) {
  // d (exp(d) * T * p) / d d at 0 = [I, -hat(T p)] for the (rho, phi) ordering.
  const SE3 t = SE3::exp((Vector6d() << 0.3, -1, 2, 0.4, 0.1, -0.7).finished());
  const Eigen::Vector3d p(0.5, -0.4, 2.0);
  auto f = [&](const Vector6d& d) { return (SE3::exp(d) * t) * p; };
  Eigen::Matrix<double, 3, 6> expected;
  expected << Eigen::Matrix3d::Identity(), -SO3::hat(t * p);
  EXPECT_LT((numeric_jacobian<3, 6>(f, Vector6d::Zero()) - expected).norm(), 1e-7);
}

TEST(SE3, InterpolationIsDecoupled) {
  const SE3 a(SO3::exp({0, 0, 0.2}), Eigen::Vector3d(0, 0, 0));
  const SE3 b(SO3::exp({0, 0, 1.2}), Eigen::Vector3d(2, 4, 0));
  const SE3 mid = interpolate(a, b, 0.25);
  EXPECT_LT((mid.translation() - Eigen::Vector3d(0.5, 1.0, 0)).norm(), 1e-12);
  EXPECT_NEAR(mid.so3().log().z(), 0.45, 1e-12);
  EXPECT_NEAR(translation_distance(a, b), std::sqrt(20.0), 1e-12);
  EXPECT_NEAR(rotation_distance(a, b), 1.0, 1e-12);
}

}  // namespace
}  // namespace coloc
