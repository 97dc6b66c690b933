// New points by triangulation (slam/mapping/triangulate): two monocular views of known points.
#include <gtest/gtest.h>

#include "slam/mapping/triangulate.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::mapping {
namespace {

using test_support::projected_keyframe;
using test_support::random_descriptors;

// 63 points 2.5-3.5 m in front of the origin, not on one plane.
std::vector<Eigen::Vector3d> scene_points() {
  std::vector<Eigen::Vector3d> world;
  for (int r = 0; r < 7; ++r)
    for (int c = 0; c < 9; ++c)
      world.emplace_back(-0.8 + 0.2 * c, -0.6 + 0.2 * r, 2.5 + 0.125 * ((r * 9 + c) % 9));
  return world;
}

KeyframeId add_view(map::Map& m, const std::vector<Eigen::Vector3d>& world,
                    const std::vector<features::Descriptor>& descriptors, const SE3& cam_from_world,
                    std::vector<int>* keypoint_of = nullptr) {
  auto v = projected_keyframe(m, world, descriptors, cam_from_world, false);
  frame::Frame& f = v.keyframe.frame;
  test_support::vocabulary().transform(f.features.descriptors, f.bow, f.feature_vector);
  if (keypoint_of) *keypoint_of = v.keypoint_of_point;
  return m.add_keyframe(std::move(v.keyframe)).id;
}

TEST(Triangulation, TwoMonocularViewsGiveThePointsWhereTheyAre) {
  map::Map m;
  const auto world = scene_points();
  const auto descriptors = random_descriptors(world.size(), 3);
  std::vector<int> keypoint_of;
  const KeyframeId a = add_view(m, world, descriptors, SE3(), &keypoint_of);
  const KeyframeId b = add_view(m, world, descriptors, SE3(SO3(), {-0.3, 0.0, 0.0}));
  const std::vector<MapPointId> created = triangulate_with_neighbours(m, a, {b});
  // Matching goes through the vocabulary's nodes; a few pairs may fall in different ones.
  EXPECT_GE(created.size(), 55u);
  for (MapPointId id : created) {
    const map::MapPoint* p = m.point(id);
    ASSERT_TRUE(p);
    ASSERT_EQ(p->observations.size(), 2u);
    const std::uint32_t k = p->observations.at(a);
    const auto it = std::find(keypoint_of.begin(), keypoint_of.end(), static_cast<int>(k));
    ASSERT_NE(it, keypoint_of.end());
    const Eigen::Vector3d& truth = world[static_cast<std::size_t>(it - keypoint_of.begin())];
    EXPECT_LT((p->position - truth).norm(), 1e-3) << "keypoint " << k;
  }
  m.update_connections(b);  // as local mapping does after triangulating
  EXPECT_EQ(test_support::map_problem(m), "");
  // Keypoints that have points now are not triangulated again.
  EXPECT_TRUE(triangulate_with_neighbours(m, a, {b}).empty());
}

TEST(Triangulation, NothingWithoutBaselineOrFromForeignDescriptors) {
  map::Map m;
  const auto world = scene_points();
  const auto descriptors = random_descriptors(world.size(), 3);
  const KeyframeId a = add_view(m, world, descriptors, SE3());
  // 5 cm: shorter than the virtual stereo baseline (bf / fx = 8 cm), depth would do better.
  const KeyframeId near = add_view(m, world, descriptors, SE3(SO3(), {-0.05, 0.0, 0.0}));
  EXPECT_TRUE(triangulate_with_neighbours(m, a, {near}).empty());
  const KeyframeId other =
      add_view(m, world, random_descriptors(world.size(), 4), SE3(SO3(), {-0.3, 0.0, 0.0}));
  EXPECT_TRUE(triangulate_with_neighbours(m, a, {other}).empty());
  EXPECT_EQ(m.point_count(), 0u);
}

}  // namespace
}  // namespace coloc::slam::mapping
