// Duplicate fusion (slam/matching/fuse): projected points either become observations of the
// keypoint they land on or merge with the point that keypoint already has.
#include <gtest/gtest.h>

#include "slam/matching/fuse.hpp"
#include "tests/slam/matching/fixture.hpp"

namespace coloc::slam::matching {
namespace {

using testing::camera_at;
using testing::GridScene;

TEST(FusePoints, UnmatchedKeypointsBecomeObservations) {
  GridScene s;
  auto view = s.view(camera_at({0.05, 0.0, 0.0}));
  const std::vector<int> keypoint_of = view.keypoint_of_point;
  const KeyframeId b = s.map.add_keyframe(std::move(view.keyframe)).id;
  EXPECT_EQ(fuse_points(s.map, b, s.ids, 3.0), 63);
  s.map.update_connections(b);  // as local mapping does after fusing
  for (std::size_t i = 0; i < s.ids.size(); ++i) {
    const map::MapPoint* p = s.map.point(s.ids[i]);
    ASSERT_TRUE(p);
    ASSERT_EQ(p->observations.count(b), 1u);
    EXPECT_EQ(p->observations.at(b), static_cast<std::uint32_t>(keypoint_of[i]));
  }
  EXPECT_EQ(test_support::map_problem(s.map), "");
  EXPECT_EQ(fuse_points(s.map, b, s.ids, 3.0), 0);  // already observed: nothing to do
}

TEST(FusePoints, DuplicatePointsMerge) {
  GridScene s;
  auto view = s.view(camera_at({0.0, 0.05, 0.0}));
  const KeyframeId b = s.map.add_keyframe(std::move(view.keyframe)).id;
  // Keyframe b made its own points for the same surface (as tracking does from depth).
  for (std::uint32_t k = 0; k < 63; ++k)
    s.map.add_point(s.map.keyframe(b)->frame.unproject_world(k), b, k);
  ASSERT_EQ(s.map.point_count(), 126u);
  EXPECT_EQ(fuse_points(s.map, b, s.ids, 3.0), 63);
  s.map.update_connections(b);
  EXPECT_EQ(s.map.point_count(), 63u);
  for (const auto& [id, p] : s.map.points()) {
    EXPECT_EQ(p.observations.size(), 2u);
  }
  EXPECT_EQ(test_support::map_problem(s.map), "");
}

TEST(FusePoints, OtherDescriptorsAreNotFused) {
  GridScene s;
  auto view = test_support::projected_keyframe(
      s.map, s.world, test_support::random_descriptors(s.world.size(), 5), SE3(), true);
  const KeyframeId b = s.map.add_keyframe(std::move(view.keyframe)).id;
  EXPECT_EQ(fuse_points(s.map, b, s.ids, 3.0), 0);
  EXPECT_EQ(s.map.keyframe(b)->frame.tracked_count(), 0u);
}

}  // namespace
}  // namespace coloc::slam::matching
