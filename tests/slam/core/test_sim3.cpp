#include <gtest/gtest.h>

#include <random>

#include "slam/core/error.hpp"
#include "slam/core/sim3.hpp"

namespace coloc {
namespace {

Eigen::Matrix4d sim3_hat(const Vector7d& xi) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() = SO3::hat(xi.segment<3>(3)) + xi(6) * Eigen::Matrix3d::Identity();
  m.topRightCorner<3, 1>() = xi.head<3>();
  return m;
}

TEST(Sim3, ExpMatchesMatrixExponentialAndLogInverts) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-8, 1e-4, 0.01, 0.7, 2.0, 3.1}) {
    for (double sigma : {0.0, 1e-9, 1e-5, 0.01, 0.3, -0.7, 1.5}) {
      Vector7d xi;
      xi.head<3>() = Eigen::Vector3d(u(rng), u(rng), u(rng));
      xi.segment<3>(3) = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * angle;
      xi(6) = sigma;
      const Eigen::Matrix4d a = sim3_hat(xi);
      Eigen::Matrix4d sum = Eigen::Matrix4d::Identity();
      Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
      for (int k = 1; k < 50; ++k) {
        term = term * a / k;
        sum += term;
      }
      const Sim3 s = Sim3::exp(xi);
      EXPECT_LT((s.matrix() - sum).norm(), 1e-10) << "angle " << angle << " sigma " << sigma;
      EXPECT_LT((s.log() - xi).norm(), 1e-9) << "angle " << angle << " sigma " << sigma;
    }
  }
}

TEST(Sim3, ComposeInverseAct) {
  const Sim3 a(2.0, SO3::exp({0.1, 0.2, 0.3}), Eigen::Vector3d(1, 2, 3));
  const Sim3 b(0.5, SO3::exp({-0.3, 0.2, 0.9}), Eigen::Vector3d(-1, 0, 2));
  const Eigen::Vector3d p(0.3, -0.2, 1.0);
  EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-12);
  EXPECT_LT(((a * a.inverse()).matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  EXPECT_LT((a * p - (a.matrix() * p.homogeneous()).head<3>()).norm(), 1e-12);
  EXPECT_LT((Sim3::from_matrix(a.matrix()).matrix() - a.matrix()).norm(), 1e-12);
  EXPECT_NEAR((a * b).scale(), 1.0, 1e-15);
}

TEST(Sim3, RejectsNonPositiveScale) {
  EXPECT_THROW(Sim3(0.0, SO3(), Eigen::Vector3d::Zero()), Error);
  EXPECT_THROW(Sim3(-1.0, SO3(), Eigen::Vector3d::Zero()), Error);
}

}  // namespace
}  // namespace coloc
