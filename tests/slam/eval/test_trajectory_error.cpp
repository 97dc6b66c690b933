#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "slam/core/error.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::eval {
namespace {

Trajectory circle(int n) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 0.1 * i;
    t.push_back({0.033 * i, SE3(SO3::exp({0, 0, a}),
                                Eigen::Vector3d(std::cos(a), std::sin(a), 0.2 * std::sin(3 * a)))});
  }
  return t;
}

TEST(Ate, KnownAnswerWithoutAlignment) {
  const Trajectory gt = circle(50);
  Trajectory est = gt;
  // Errors of exactly 0.1 m on even poses and 0.3 m on odd poses.
  for (std::size_t i = 0; i < est.size(); ++i) {
    est[i].world_from_cam.translation() += Eigen::Vector3d(0, 0, i % 2 == 0 ? 0.1 : -0.3);
  }
  const AteResult r = compute_ate(gt, est, {.alignment = Alignment::kNone});
  EXPECT_EQ(r.translation.count, 50u);
  EXPECT_NEAR(r.translation.rmse, std::sqrt((0.01 + 0.09) / 2), 1e-12);
  EXPECT_NEAR(r.translation.mean, 0.2, 1e-12);
  EXPECT_NEAR(r.translation.median, 0.2, 1e-12);  // numpy: mean of the two middle values
  EXPECT_NEAR(r.translation.std, 0.1, 1e-12);     // population std
  EXPECT_NEAR(r.translation.min, 0.1, 1e-12);
  EXPECT_NEAR(r.translation.max, 0.3, 1e-12);
}

TEST(Ate, AlignmentRemovesRigidAndSimilarityMotion) {
  const Trajectory gt = circle(60);
  const Sim3 moved(2.5, SO3::exp({0.3, 1.0, -0.2}), Eigen::Vector3d(5, -3, 1));
  Trajectory est;
  for (const auto& p : gt) {
    est.push_back({p.timestamp + 0.004, SE3(moved.so3() * p.world_from_cam.so3(),
                                            moved * p.world_from_cam.translation())});
  }
  const AteResult sim3 = compute_ate(gt, est, {.alignment = Alignment::kSim3});
  EXPECT_LT(sim3.translation.rmse, 1e-9);
  EXPECT_NEAR(sim3.gt_from_est.scale(), 1.0 / 2.5, 1e-12);
  const AteResult se3 = compute_ate(gt, est, {.alignment = Alignment::kSE3});
  EXPECT_GT(se3.translation.rmse, 0.1);  // scale cannot be explained rigidly
  EXPECT_EQ(se3.gt_from_est.scale(), 1.0);
}

// Horn's closed-form quaternion method: an alignment independent of the SVD used by coloc.
SE3 horn(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  Eigen::Vector3d ms = Eigen::Vector3d::Zero();
  Eigen::Vector3d md = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    ms += src[i];
    md += dst[i];
  }
  ms /= static_cast<double>(src.size());
  md /= static_cast<double>(src.size());
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i)
    s += (src[i] - ms) * (dst[i] - md).transpose();
  Eigen::Matrix4d n;
  n << s(0, 0) + s(1, 1) + s(2, 2), s(1, 2) - s(2, 1), s(2, 0) - s(0, 2), s(0, 1) - s(1, 0),
      s(1, 2) - s(2, 1), s(0, 0) - s(1, 1) - s(2, 2), s(0, 1) + s(1, 0), s(2, 0) + s(0, 2),
      s(2, 0) - s(0, 2), s(0, 1) + s(1, 0), -s(0, 0) + s(1, 1) - s(2, 2), s(1, 2) + s(2, 1),
      s(0, 1) - s(1, 0), s(2, 0) + s(0, 2), s(1, 2) + s(2, 1), -s(0, 0) - s(1, 1) + s(2, 2);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(n);
  const Eigen::Vector4d q = eig.eigenvectors().col(3);
  const SO3 r(Eigen::Quaterniond(q(0), q(1), q(2), q(3)));
  return {r, md - (r * ms)};
}

TEST(Ate, RealTumGroundTruthAgainstPerturbedCopy) {
  COLOC_REQUIRE_DATA(file, "tum_fr1_xyz_37f/groundtruth.txt");
  const Trajectory gt = read_tum_trajectory(file);
  const SE3 moved(SO3::exp({-0.4, 0.2, 2.0}), Eigen::Vector3d(0.7, 1.5, -0.3));
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.01);
  Trajectory est;
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : gt) {
    const Eigen::Vector3d t = moved * p.world_from_cam.translation() +
                              Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    est.push_back({p.timestamp, SE3(moved.so3() * p.world_from_cam.so3(), t)});
    src.push_back(t);
    dst.push_back(p.world_from_cam.translation());
  }
  const AteResult r = compute_ate(gt, est);
  ASSERT_EQ(r.translation.count, gt.size());
  // The alignment found is the inverse of the perturbation (up to noise)...
  EXPECT_LT(rotation_distance(r.gt_from_est.to_se3(), moved.inverse()), 2e-3);
  // ...and agrees with Horn's method to numerical precision, and so does the RMSE.
  const SE3 reference = horn(src, dst);
  EXPECT_LT((r.gt_from_est.matrix() - reference.matrix()).norm(), 1e-9);
  double sq = 0.0;
  for (std::size_t i = 0; i < src.size(); ++i)
    sq += (reference * src[i] - dst[i]).squaredNorm();
  EXPECT_NEAR(r.translation.rmse, std::sqrt(sq / static_cast<double>(src.size())), 1e-9);
  EXPECT_NEAR(r.translation.rmse, 0.01 * std::sqrt(3.0), 2e-3);
}

TEST(Rpe, KnownAnswer) {
  const Trajectory gt = circle(40);
  Trajectory est = gt;
  // A rotation error of 1 degree about z applied from pose 20 onward: exactly one relative
  // pose (19 -> 20) is wrong, by 1 degree and by the lever arm of the rotation.
  const SE3 kick(SO3::exp({0, 0, M_PI / 180.0}), Eigen::Vector3d::Zero());
  for (std::size_t i = 20; i < est.size(); ++i)
    est[i].world_from_cam = kick * est[i].world_from_cam;
  const RpeResult r = compute_rpe(gt, est, {});
  ASSERT_EQ(r.rotation.count, 39u);
  EXPECT_NEAR(r.rotation.max, 1.0, 1e-9);
  EXPECT_NEAR(r.rotation.min, 0.0, 1e-9);
  EXPECT_NEAR(r.rotation_errors[19], 1.0, 1e-9);
  EXPECT_GT(r.translation_errors[19], 0.0);
  EXPECT_NEAR(r.translation_errors[5], 0.0, 1e-12);
  EXPECT_THROW(compute_rpe(gt, est, {.delta = 0}), Error);
  EXPECT_THROW(compute_rpe(gt, est, {.delta = 40}), Error);
}

// What `coloc bench loop` judges a loop by: the relative pose it asserted against the truth.
TEST(RelativePoseError, NearestPosesAndKnownError) {
  const Trajectory gt = circle(50);
  EXPECT_TRUE(nearest_pose(gt, 0.033 * 7 + 0.01).has_value());
  EXPECT_FALSE(nearest_pose(gt, 0.033 * 49 + 0.5).has_value());
  const SE3 b_from_a = gt[20].world_from_cam.inverse() * gt[3].world_from_cam;
  const auto exact = relative_pose_error(gt, gt[3].timestamp, gt[20].timestamp, b_from_a);
  ASSERT_TRUE(exact);
  EXPECT_NEAR(exact->translation, 0.0, 1e-12);
  EXPECT_NEAR(exact->rotation_deg, 0.0, 1e-9);
  // Off by 0.3 m along b's x axis and 2 degrees about its z axis.
  const SE3 off = SE3(SO3::exp({0, 0, 2.0 * M_PI / 180.0}), Eigen::Vector3d(0.3, 0, 0)) * b_from_a;
  const auto e = relative_pose_error(gt, gt[3].timestamp, gt[20].timestamp, off);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->rotation_deg, 2.0, 1e-9);
  EXPECT_GT(e->translation, 0.2);  // 0.3 m, give or take the 2 degrees acting on the lever arm
  EXPECT_FALSE(relative_pose_error(gt, -5.0, gt[20].timestamp, b_from_a).has_value());
}

TEST(Ate, TooFewAssociationsIsAnError) {
  Trajectory gt = circle(10);
  Trajectory est = circle(10);
  for (auto& p : est)
    p.timestamp += 100.0;
  EXPECT_THROW(compute_ate(gt, est), Error);
  EXPECT_THROW(parse_alignment("affine"), Error);
}

}  // namespace
}  // namespace coloc::eval
