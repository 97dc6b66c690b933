#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "slam/core/error.hpp"
#include "slam/core/trajectory.hpp"
#include "tests/testing/data.hpp"

namespace coloc {
namespace {

TEST(Trajectory, WriteReadRoundTrip) {
  const auto dir = testing::temp_dir("trajectory");
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    t.push_back({1305031102.175304 + 0.033 * i,
                 SE3::exp((Vector6d() << 0.1 * i, 0.2, -0.3, 0.01 * i, 0.5, -0.2).finished())});
  }
  write_tum_trajectory(dir / "t.txt", t);
  const Trajectory back = read_tum_trajectory(dir / "t.txt");
  ASSERT_EQ(back.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(back[i].timestamp, t[i].timestamp, 1e-6);
    EXPECT_LT((back[i].world_from_cam.matrix() - t[i].world_from_cam.matrix()).norm(), 1e-8);
  }
}

// No non-finite number reaches a trajectory file: such a pose is a missing row (lost), counted.
TEST(Trajectory, NonFinitePosesAreLeftOutAndCounted) {
  const auto dir = testing::temp_dir("trajectory_nan");
  Trajectory t(3);
  for (std::size_t i = 0; i < t.size(); ++i)
    t[i].timestamp = 1.0 + static_cast<double>(i);
  t[1].world_from_cam.translation().z() = std::nan("");
  EXPECT_EQ(write_tum_trajectory(dir / "t.txt", t), 1u);
  const Trajectory back = read_tum_trajectory(dir / "t.txt");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_DOUBLE_EQ(back[1].timestamp, 3.0);
}

TEST(Trajectory, MalformedLineNamesFileAndLine) {
  const auto dir = testing::temp_dir("trajectory_bad");
  std::ofstream(dir / "bad.txt") << "# comment\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0\n";
  try {
    read_tum_trajectory(dir / "bad.txt");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 3);
    EXPECT_NE(std::string(e.what()).find("bad.txt:3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_tum_trajectory(dir / "missing.txt"), Error);
}

TEST(Trajectory, ReadsRealTumGroundTruth) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const Trajectory gt = read_tum_trajectory(dir / "groundtruth.txt");
  ASSERT_GT(gt.size(), 100u);
  for (std::size_t i = 1; i < gt.size(); ++i)
    EXPECT_GE(gt[i].timestamp, gt[i - 1].timestamp);
}

TEST(Trajectory, AssociationIsGreedyNearestFirst) {
  Trajectory a;
  Trajectory b;
  for (double t : {0.0, 0.1, 0.2, 0.3})
    a.push_back({t, SE3()});
  for (double t : {0.005, 0.095, 0.12, 0.5})
    b.push_back({t, SE3()});
  const auto pairs = associate_by_time(a, b, 0.02);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].first, 0u);
  EXPECT_EQ(pairs[0].second, 0u);
  EXPECT_EQ(pairs[1].first, 1u);
  EXPECT_EQ(pairs[1].second, 1u);
}

TEST(Trajectory, InOrderAssociationKeepsEveryFrame) {
  // Colour at 0, 33, 66 ms; depth 15 ms earlier each, except the second which is 2 ms late:
  // greedy nearest-first pairs colour 1 with depth 1... and leaves a frame out; in order, all
  // three pair up.
  const std::vector<double> color = {0.000, 0.033, 0.066, 0.099};
  const std::vector<double> depth = {-0.015, 0.0175, 0.051, 0.084};
  const auto pairs = associate_in_order(color, depth, 0.02);
  ASSERT_EQ(pairs.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(pairs[k].first, k);
    EXPECT_EQ(pairs[k].second, k);
  }
  // Among equally long matchings the smaller total |dt| wins.
  const auto one = associate_in_order({1.0}, {0.99, 1.005}, 0.02);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].second, 1u);
  EXPECT_TRUE(associate_in_order({}, {1.0}, 0.02).empty());
}

}  // namespace
}  // namespace coloc
