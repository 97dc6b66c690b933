// Fusion of sightings: robust mean, outliers dropped, ambiguity resolved by agreement.

#include <gtest/gtest.h>

#include <random>

#include "markers/marker_pose.hpp"
#include "markers/sighting_fusion.hpp"
#include "slam/core/error.hpp"

namespace coloc::markers {
namespace {

using Corners = std::array<Eigen::Vector3d, 4>;

Corners corners_of(const SE3& global_from_marker, double size) {
  Corners out;
  const auto local = marker_corners(size);
  for (int c = 0; c < 4; ++c)
    out[c] = global_from_marker * local[c];
  return out;
}

const SE3 kTruth(SO3::from_axis_angle(Eigen::Vector3d(0.2, 1.0, 0.1).normalized(), 1.1),
                 Eigen::Vector3d(4.0, -2.0, 1.3));

Sighting noisy_sighting(std::mt19937& rng, double sigma, const std::string& name) {
  std::normal_distribution<double> n(0.0, sigma);
  Sighting s;
  s.id = 5;
  s.image = name;
  s.edge_length = 0.2;
  s.distance = 1.5;
  s.corners = corners_of(kTruth, 0.2);
  for (auto& c : s.corners)
    c += Eigen::Vector3d(n(rng), n(rng), n(rng));
  s.alternative = s.corners;
  return s;
}

TEST(SightingFusion, RobustMeanDropsOutliers) {
  std::mt19937 rng(11);
  std::vector<Sighting> sightings;
  for (int i = 0; i < 6; ++i)
    sightings.push_back(noisy_sighting(rng, 0.001, "img" + std::to_string(i)));
  Sighting outlier = noisy_sighting(rng, 0.001, "bad");
  for (auto& c : outlier.corners)
    c += Eigen::Vector3d(0.05, 0.0, -0.02);
  sightings.push_back(outlier);
  const MapMarker m = fuse_sightings(sightings, {});
  EXPECT_EQ(m.id, 5);
  EXPECT_EQ(m.sightings, 6);
  EXPECT_EQ(m.rejected_sightings, 1);
  EXPECT_EQ(std::count(m.images.begin(), m.images.end(), "bad"), 0);
  EXPECT_LT(corner_rms(m.corners, corners_of(kTruth, 0.2)), 0.001);
  EXPECT_GT(m.residual, 0.0005);
  EXPECT_LT(m.residual, 0.003);
  EXPECT_DOUBLE_EQ(m.edge_length, 0.2);
}

TEST(SightingFusion, AmbiguousSightingsTakeTheCandidateTheOthersSupport) {
  std::mt19937 rng(12);
  // The mirrored pose: same centre, tilted the other way (corners off by centimetres).
  const SE3 mirrored =
      kTruth * SE3(SO3::from_axis_angle(Eigen::Vector3d::UnitX(), 0.5), {0, 0, 0.01});
  std::vector<Sighting> sightings;
  for (int i = 0; i < 4; ++i) {
    Sighting s = noisy_sighting(rng, 0.0005, "img" + std::to_string(i));
    s.ambiguous = i < 3;
    if (i % 2 == 0 && s.ambiguous) {  // the smaller-error candidate was the wrong one
      s.alternative = s.corners;
      s.corners = corners_of(mirrored, 0.2);
    } else {
      s.alternative = corners_of(mirrored, 0.2);
    }
    sightings.push_back(s);
  }
  const MapMarker m = fuse_sightings(sightings, {});
  EXPECT_EQ(m.sightings, 4);
  EXPECT_EQ(m.rejected_sightings, 0);
  EXPECT_EQ(m.ambiguous_sightings, 3);
  EXPECT_LT(corner_rms(m.corners, corners_of(kTruth, 0.2)), 0.0005);
  EXPECT_LT(m.residual, 0.001);
}

TEST(SightingFusion, CloserSightingsWeighMore) {
  std::mt19937 rng(1);
  Sighting near = noisy_sighting(rng, 0.0, "near");
  Sighting far = noisy_sighting(rng, 0.0, "far");
  near.distance = 1.0;
  far.distance = 3.0;
  for (auto& c : far.corners)
    c += Eigen::Vector3d(0.005, 0, 0);  // within the gate
  const MapMarker m = fuse_sightings({near, far}, {});
  EXPECT_EQ(m.sightings, 2);
  // Weights 1 : 1/9: the fused corners sit 0.5 mm from the near sighting.
  EXPECT_NEAR((m.corners[0] - near.corners[0]).x(), 0.005 / 10.0, 1e-9);
}

TEST(SightingFusion, GroupsByIdAndRejectsMixedInput) {
  std::mt19937 rng(2);
  Sighting a = noisy_sighting(rng, 0.0, "a");
  Sighting b = noisy_sighting(rng, 0.0, "b");
  b.id = 9;
  const auto all = fuse_all({a, b, a}, {});
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all.at(5).sightings, 2);
  EXPECT_EQ(all.at(9).sightings, 1);
  EXPECT_NEAR(all.at(9).residual, 0.0, 1e-12);
  EXPECT_THROW(fuse_sightings({a, b}, {}), Error);
  EXPECT_THROW(fuse_sightings({}, {}), Error);
  EXPECT_THROW(fuse_sightings({a}, {.min_gate = 0.0}), Error);
}

}  // namespace
}  // namespace coloc::markers
