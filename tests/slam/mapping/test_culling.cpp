// Keyframe culling in practice: the synthetic camera hovers over one area for several seconds
// with a keyframe every few frames, so later keyframes see what earlier ones saw and local
// mapping must cull the redundant ones. The map must stay consistent (no id of an erased
// keyframe left in points, covisibility or spanning tree; the tree stays a tree) and tracking
// must keep its accuracy.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <memory>
#include <set>
#include <vector>

#include "slam/eval/trajectory_error.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/system/system.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::system {
namespace {

using synthetic::SyntheticFrame;
using synthetic::SyntheticRgbdScene;
using synthetic::SyntheticSceneOptions;
using synthetic::SyntheticTrajectory;

// Adds a keyframe observing `points` at keypoints 0.. and `fresh` new points after them.
KeyframeId add_observer(map::Map& m, double x, const std::vector<MapPointId>& points,
                        std::size_t fresh, std::vector<MapPointId>* created = nullptr) {
  map::Keyframe kf = test_support::row_keyframe(m, points.size() + fresh, {x, 0.0, 0.0});
  std::copy(points.begin(), points.end(), kf.frame.points.begin());
  const KeyframeId id = m.add_keyframe(std::move(kf)).id;
  for (std::size_t i = points.size(); i < points.size() + fresh; ++i) {
    const auto index = static_cast<std::uint32_t>(i);
    const MapPointId p = m.add_point(m.keyframe(id)->frame.unproject_world(index), id, index).id;
    if (created) created->push_back(p);
  }
  m.update_connections(id);
  return id;
}

std::vector<MapPointId> slice(const std::vector<MapPointId>& v, std::size_t from, std::size_t n) {
  return {v.begin() + static_cast<long>(from), v.begin() + static_cast<long>(from + n)};
}

// Tree a <- b <- {c, d}: erasing b must hand c and d to keyframes still in the tree (ORB-SLAM
// re-attaches children to the parent or to a sibling already re-attached), leave no id of b
// anywhere, and keep b's pose reachable for the frames that referenced it.
TEST(KeyframeCulling, ErasingAParentReattachesItsChildren) {
  map::Map m;
  std::vector<MapPointId> pa, pb;
  const KeyframeId a = add_observer(m, 0.0, {}, 60, &pa);
  const KeyframeId b = add_observer(m, 0.05, pa, 30, &pb);  // sees all of a's, adds 30
  std::vector<MapPointId> seen_c = slice(pb, 0, 30);
  for (MapPointId p : slice(pa, 0, 10))
    seen_c.push_back(p);
  const KeyframeId c = add_observer(m, 0.1, seen_c, 0);
  std::vector<MapPointId> seen_d = slice(pb, 0, 20);
  for (MapPointId p : slice(pa, 0, 5))
    seen_d.push_back(p);
  const KeyframeId d = add_observer(m, 0.15, seen_d, 0);
  ASSERT_EQ(m.keyframe(b)->parent, a);
  ASSERT_EQ(m.keyframe(c)->parent, b);
  ASSERT_EQ(m.keyframe(d)->parent, b);
  ASSERT_EQ(test_support::map_problem(m), "");

  const SE3 pose_b = m.keyframe(b)->cam_from_world();
  m.erase_keyframe(b);
  EXPECT_FALSE(m.keyframe(b));
  EXPECT_EQ(test_support::map_problem(m), "");
  for (KeyframeId k : {c, d}) {
    const KeyframeId parent = m.keyframe(k)->parent;
    EXPECT_TRUE(parent == a || parent == c) << "keyframe " << k.value();
    EXPECT_TRUE(m.keyframe(parent)->children.count(k));
  }
  const auto pose = m.keyframe_pose(b);
  ASSERT_TRUE(pose.has_value());
  EXPECT_LT(translation_distance(*pose, pose_b), 1e-12);
}

// Covisibility stays symmetric: when c's shared points with b fall below the threshold, both
// sides lose the edge; erasing c afterwards leaves no dangling id.
TEST(KeyframeCulling, CovisibilityEdgesStaySymmetricThroughUpdatesAndErasure) {
  map::Map m;
  std::vector<MapPointId> pa;
  const KeyframeId a = add_observer(m, 0.0, {}, 40, &pa);
  const KeyframeId b = add_observer(m, 0.05, slice(pa, 0, 30), 0);
  const KeyframeId c = add_observer(m, 0.1, slice(pa, 0, 20), 0);
  ASSERT_EQ(m.keyframe(b)->covisibility.at(c), 20);
  for (MapPointId p : slice(pa, 0, 10))
    m.erase_observation(p, c);
  m.update_connections(c);  // 10 shared with a and with b: c keeps only its best edge
  ASSERT_EQ(m.keyframe(c)->covisibility.size(), 1u);
  for (KeyframeId k : {a, b}) {
    EXPECT_EQ(m.keyframe(k)->covisibility.count(c), m.keyframe(c)->covisibility.count(k))
        << "keyframe " << k;
  }
  EXPECT_EQ(test_support::map_problem(m), "");
  m.erase_keyframe(c);
  EXPECT_EQ(test_support::map_problem(m), "");
  EXPECT_EQ(m.keyframe(b)->covisibility.count(c), 0u);
  EXPECT_EQ(m.keyframe(a)->covisibility.count(c), 0u);
}

TEST(KeyframeCulling, HoveringCameraCullsRedundantKeyframesAndKeepsTheMapConsistent) {
  SyntheticSceneOptions scene_options;
  scene_options.trajectory = SyntheticTrajectory::kHover;
  scene_options.frames = 120;  // 4 s: 1.6 oscillations
  scene_options.amplitude = 0.1;
  scene_options.rotation_amplitude = 0.1;
  scene_options.hover_period_s = 2.5;
  // The far wall just beyond the close-depth limit (ThDepth * baseline = 3.05 m): frames keep
  // few close points, so the RGB-D "close points" rule asks for a keyframe every few frames,
  // as on TUM-like scenes, and the hovering camera piles them up over one area.
  scene_options.room_max.z() = 3.1;
  const SyntheticRgbdScene scene(scene_options);
  SystemOptions options;
  options.tracking.wait_for_sink = true;  // deterministic
  options.detect_markers = false;
  options.tracking.min_frames_between_keyframes = 3;
  System slam(scene.settings(), test_support::vocabulary(), options);
  Trajectory truth;
  int keyframes_made = 0, lost = 0;
  for (int i = 0; i < scene.size(); ++i) {
    const SyntheticFrame f = scene.frame(i);
    truth.push_back({f.timestamp, f.world_from_cam});
    const auto r = slam.track(f.color, f.depth, f.timestamp);
    keyframes_made += r.keyframe ? 1 : 0;
    lost += r.state == tracking::TrackingState::kOk ? 0 : 1;
  }
  slam.shutdown();
  const SystemSummary s = slam.summary();
  EXPECT_EQ(lost, 0);
  EXPECT_GT(s.mapping.keyframes_culled, 0);  // 14 of 33 when written
  EXPECT_EQ(s.keyframes + static_cast<std::size_t>(s.mapping.keyframes_culled),
            static_cast<std::size_t>(keyframes_made));
  EXPECT_EQ(slam.with_map(test_support::map_problem), "");
  // Frames whose reference keyframe was culled still get poses (through the erased chain).
  const Trajectory estimate = slam.trajectory();
  ASSERT_EQ(estimate.size(), truth.size());
  const auto ate = eval::compute_ate(truth, estimate);
  EXPECT_LT(ate.translation.rmse, 0.005);
  std::cout << "hover: " << keyframes_made << " keyframes made, " << s.mapping.keyframes_culled
            << " culled, " << s.keyframes << " kept; ATE RMSE " << 1e3 * ate.translation.rmse
            << " mm\n"
            << s.describe() << "\n";
}

}  // namespace
}  // namespace coloc::slam::system
