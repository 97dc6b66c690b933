#include <gtest/gtest.h>

#include <random>

#include "slam/core/align.hpp"
#include "slam/core/error.hpp"

namespace coloc {
namespace {

struct Scene {
  std::vector<Eigen::Vector3d> src, dst;
};

Scene make_scene(const Sim3& dst_from_src, int n, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::normal_distribution<double> g(0.0, noise);
  Scene s;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    s.src.push_back(p);
    s.dst.push_back(dst_from_src * p + Eigen::Vector3d(g(rng), g(rng), g(rng)));
  }
  return s;
}

TEST(Align, ExactSE3AndSim3) {
  const Sim3 truth(1.7, SO3::exp({0.3, -2.0, 0.5}), Eigen::Vector3d(4, -1, 2));
  const Scene s = make_scene(truth, 10, 0.0, 1);
  const AlignmentResult r = align_points(s.src, s.dst, {.estimate_scale = true});
  ASSERT_TRUE(r.usable);
  EXPECT_LT((r.dst_from_src.matrix() - truth.matrix()).norm(), 1e-10);
  EXPECT_LT(r.rmse, 1e-10);

  const Sim3 rigid(1.0, SO3::exp({0.3, -2.0, 0.5}), Eigen::Vector3d(4, -1, 2));
  const Scene s2 = make_scene(rigid, 10, 0.0, 2);
  const AlignmentResult r2 = align_points(s2.src, s2.dst);
  ASSERT_TRUE(r2.usable);
  EXPECT_EQ(r2.dst_from_src.scale(), 1.0);
  EXPECT_LT((r2.dst_from_src.matrix() - rigid.matrix()).norm(), 1e-10);
}

TEST(Align, NoisyDataRecoversKnownTransform) {
  const Sim3 truth(0.8, SO3::exp({-1.0, 0.4, 2.9}), Eigen::Vector3d(-2, 5, 0.3));
  const Scene s = make_scene(truth, 2000, 0.01, 5);
  const AlignmentResult r = align_points(s.src, s.dst, {.estimate_scale = true});
  ASSERT_TRUE(r.usable);
  EXPECT_NEAR(r.dst_from_src.scale(), 0.8, 1e-3);
  EXPECT_LT(angular_distance(r.dst_from_src.so3(), truth.so3()), 1e-3);
  EXPECT_LT((r.dst_from_src.translation() - truth.translation()).norm(), 5e-3);
  // RMSE of isotropic noise with sigma 1 cm per axis is ~ sqrt(3) cm.
  EXPECT_NEAR(r.rmse, 0.01 * std::sqrt(3.0), 2e-3);
}

TEST(Align, WeightsSuppressOutliers) {
  const Sim3 truth(1.0, SO3::exp({0.2, 0.1, -0.4}), Eigen::Vector3d(1, 1, 1));
  Scene s = make_scene(truth, 20, 0.0, 9);
  s.dst[3] += Eigen::Vector3d(5, 0, 0);  // gross outlier
  std::vector<double> w(20, 1.0);
  w[3] = 0.0;
  const AlignmentResult weighted = align_points(s.src, s.dst, {.weights = w});
  ASSERT_TRUE(weighted.usable);
  EXPECT_LT((weighted.dst_from_src.matrix() - truth.matrix()).norm(), 1e-10);
  const AlignmentResult unweighted = align_points(s.src, s.dst);
  EXPECT_GT((unweighted.dst_from_src.matrix() - truth.matrix()).norm(), 1e-2);
}

TEST(Align, DegenerateInputIsReportedNotThrown) {
  std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_FALSE(align_points(two, two).usable);
  std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  EXPECT_FALSE(align_points(line, line).usable);
  // A planar set is enough.
  std::vector<Eigen::Vector3d> plane = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  EXPECT_TRUE(align_points(plane, plane).usable);
  EXPECT_THROW(align_points(two, line), Error);
  EXPECT_THROW(align_points(line, line, {.weights = {1.0}}), Error);
}

}  // namespace
}  // namespace coloc
