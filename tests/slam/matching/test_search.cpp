// Projection searches (slam/matching/search): each must find the keypoint where a point
// projects, and only there.
#include <gtest/gtest.h>

#include <numbers>

#include "slam/matching/search.hpp"
#include "tests/slam/matching/fixture.hpp"

namespace coloc::slam::matching {
namespace {

using testing::camera_at;
using testing::GridScene;

// Number of keypoints of `view` matched to the point they really show.
int correct_matches(const GridScene& s, const test_support::ProjectedKeyframe& view) {
  int n = 0;
  for (std::size_t i = 0; i < s.ids.size(); ++i) {
    const int k = view.keypoint_of_point[i];
    if (k >= 0 && view.keyframe.frame.points[static_cast<std::size_t>(k)] == s.ids[i]) ++n;
  }
  return n;
}

int matched(const frame::Frame& f) {
  int n = 0;
  for (MapPointId p : f.points)
    n += p.valid() ? 1 : 0;
  return n;
}

TEST(SearchLocalPoints, MatchesEveryVisiblePointToItsOwnKeypoint) {
  GridScene s;
  auto view = s.view(camera_at({0.03, -0.02, 0.1}));
  std::vector<MapPointId> visible;
  const int n = search_local_points(view.keyframe.frame, s.ids, s.map, 1.0, &visible);
  EXPECT_EQ(n, 63);
  EXPECT_EQ(correct_matches(s, view), 63);
  EXPECT_EQ(visible.size(), 63u);
  // The search only reads the map: the caller counts `visible` (tracking does, localizing not).
  EXPECT_EQ(s.map.point(s.ids[10])->visible, 1);
}

TEST(SearchLocalPoints, SkipsPointsOutsideTheFrustumAndForeignDescriptors) {
  GridScene s;
  // Turned around: every point is behind the camera.
  auto behind = s.view(SE3(SO3::exp({0, std::numbers::pi, 0}), Eigen::Vector3d::Zero()));
  std::vector<MapPointId> visible;
  EXPECT_EQ(search_local_points(behind.keyframe.frame, s.ids, s.map, 1.0, &visible), 0);
  EXPECT_TRUE(visible.empty());
  // Same place, other descriptors (distances near 128 > TH_HIGH): visible, never matched.
  auto foreign = test_support::projected_keyframe(
      s.map, s.world, test_support::random_descriptors(s.world.size(), 99), SE3(), true);
  EXPECT_EQ(search_local_points(foreign.keyframe.frame, s.ids, s.map, 1.0, &visible), 0);
  EXPECT_EQ(visible.size(), 63u);
}

TEST(SearchFromLastFrame, FollowsThePredictedMotionOnly) {
  GridScene s;
  const frame::Frame& last = s.map.keyframe(s.first)->frame;
  const SE3 truth = camera_at({0.04, 0.01, 0.0});
  auto good = s.view(truth);
  EXPECT_EQ(search_from_last_frame(good.keyframe.frame, last, s.map, 7.0), 63);
  EXPECT_EQ(correct_matches(s, good), 63);
  // A prediction 10 cm off moves every projection by 25 px: beyond the 7 px window, and the
  // grid's neighbours are 50 px away, so nothing may match.
  auto wrong = s.view(truth);
  wrong.keyframe.frame.cam_from_world = camera_at({0.14, 0.01, 0.0});
  EXPECT_EQ(search_from_last_frame(wrong.keyframe.frame, last, s.map, 7.0), 0);
  EXPECT_EQ(matched(wrong.keyframe.frame), 0);
}

TEST(SearchKeyframePoints, AddsOnlyPointsNotMatchedYet) {
  GridScene s;
  auto view = s.view(camera_at({-0.05, 0.0, 0.05}));
  frame::Frame& f = view.keyframe.frame;
  for (std::size_t i = 0; i < 5; ++i)
    f.points[static_cast<std::size_t>(view.keypoint_of_point[i])] = s.ids[i];
  const int n = search_keyframe_points(f, *s.map.keyframe(s.first), s.map, 10.0, 100);
  EXPECT_EQ(n, 58);
  EXPECT_EQ(correct_matches(s, view), 63);
}

TEST(RotationOutliers, KeepsTheThreeFullestBinsAboveATenth) {
  std::vector<float> angles;
  for (int i = 0; i < 50; ++i)
    angles.push_back(0.10f + 0.001f * static_cast<float>(i % 5));  // the consistent majority
  for (int i = 0; i < 20; ++i)
    angles.push_back(1.0f);  // a second bin with more than a tenth: kept
  for (int i = 0; i < 3; ++i)
    angles.push_back(3.0f);  // a third bin under a tenth of the first: dropped
  angles.push_back(-0.1f + 2.0f * static_cast<float>(std::numbers::pi));  // wraps: last bin
  // Bins in order: the three at 3.0 rad (bin 14), then the wrapped one (bin 29).
  EXPECT_EQ(rotation_outliers(angles), (std::vector<std::size_t>{70, 71, 72, 73}));
}

}  // namespace
}  // namespace coloc::slam::matching
