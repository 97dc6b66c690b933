#pragma once
// A small scene for the matching tests: a 9 x 7 grid of points on a plane 2 m in front of the
// first keyframe (about 50 px apart in the image, so only geometry and descriptors decide), seen
// by keyframe `first` with depth, each keypoint holding its point.
#include <vector>

#include "slam/map/map.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::matching::testing {

struct GridScene {
  map::Map map;
  std::vector<Eigen::Vector3d> world;
  std::vector<features::Descriptor> descriptors;
  std::vector<MapPointId> ids;  // ids[i] is world[i]
  KeyframeId first;

  GridScene() {
    for (int r = 0; r < 7; ++r)
      for (int c = 0; c < 9; ++c)
        world.emplace_back(-0.8 + 0.2 * c, -0.6 + 0.2 * r, 2.0);
    descriptors = test_support::random_descriptors(world.size(), 11);
    auto a = test_support::projected_keyframe(map, world, descriptors, SE3(), true);
    first = map.add_keyframe(std::move(a.keyframe)).id;
    for (std::size_t i = 0; i < world.size(); ++i)
      ids.push_back(
          map.add_point(world[i], first, static_cast<std::uint32_t>(a.keypoint_of_point[i])).id);
  }

  // A frame at `cam_from_world` seeing the grid (keypoints at the exact projections), no matches.
  test_support::ProjectedKeyframe view(const SE3& cam_from_world, bool depth = true) {
    return test_support::projected_keyframe(map, world, descriptors, cam_from_world, depth);
  }
};

// cam_from_world of a camera at `centre` (world axes).
inline SE3 camera_at(const Eigen::Vector3d& centre) {
  return SE3(SO3(), -centre);
}

}  // namespace coloc::slam::matching::testing
