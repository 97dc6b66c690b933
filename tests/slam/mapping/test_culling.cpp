// Keyframe culling in practice: the synthetic camera hovers over one area for several seconds
// with a keyframe every few frames, so later keyframes see what earlier ones saw and local
// mapping must cull the redundant ones. The map must stay consistent (no id of an erased
// keyframe left in points, covisibility or spanning tree; the tree stays a tree) and tracking
// must keep its accuracy.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <iostream>
#include <memory>
#include <set>
#include <vector>

#include "slam/eval/trajectory_error.hpp"
#include "slam/mapping/culling.hpp"
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

// Three keyframes 5 cm apart in a row, looking the same way and seeing the same 40 points.
std::array<KeyframeId, 3> three_in_a_row(map::Map& m) {
  std::vector<MapPointId> points;
  const KeyframeId a = add_observer(m, 0.0, {}, 40, &points);
  return {a, add_observer(m, 0.05, points, 0), add_observer(m, 0.10, points, 0)};
}

// ORB-SLAM's measure: the share of a keyframe's close points that three other keyframes see.
TEST(KeyframeCulling, RedundantShareCountsPointsSeenByThreeOthers) {
  map::Map m;
  std::vector<MapPointId> pa;
  const KeyframeId a = add_observer(m, 0.0, {}, 40, &pa);
  add_observer(m, 0.05, pa, 0);                                     // b sees all 40
  add_observer(m, 0.10, slice(pa, 0, 30), 0);                       // c sees 30
  const KeyframeId d = add_observer(m, 0.15, slice(pa, 0, 10), 5);  // d sees 10, adds 5
  EXPECT_DOUBLE_EQ(mapping::redundant_share(m, a), 10.0 / 40.0);
  EXPECT_DOUBLE_EQ(mapping::redundant_share(m, d), 10.0 / 15.0);
}

// The lower share applies only between neighbours that look the same way: a walk, not a turn.
TEST(KeyframeCulling, StraightStretchIsJudgedByTheNeighboursDirections) {
  map::Map m;
  const auto [a, b, c] = three_in_a_row(m);
  EXPECT_TRUE(mapping::between_same_view(m, b, 5.0));
  EXPECT_FALSE(mapping::between_same_view(m, a, 5.0));  // nothing before it
  EXPECT_FALSE(mapping::between_same_view(m, c, 5.0));  // nothing after it yet

  // c turned by 8 degrees about the vertical: b is inside a 10-degree stretch, not a 5-degree one.
  map::Keyframe& kc = *m.keyframe(c);
  const Eigen::Vector3d centre_c = kc.cam_from_world().inverse().translation();
  const SO3 cam_from_world_c = SO3::from_axis_angle(Eigen::Vector3d::UnitY(), 8.0 * M_PI / 180.0);
  kc.frame.cam_from_world = SE3(cam_from_world_c, -(cam_from_world_c * centre_c));
  EXPECT_NEAR(mapping::axis_angle_deg(*m.keyframe(b), kc), 8.0, 1e-9);
  EXPECT_FALSE(mapping::between_same_view(m, b, 5.0));
  EXPECT_TRUE(mapping::between_same_view(m, b, 10.0));
}

// A keyframe holding a marker's view is culled only while two other keyframes see that marker.
TEST(KeyframeCulling, KeepsTheLastViewsOfAMarker) {
  map::Map m;
  const auto [a, b, c] = three_in_a_row(m);
  EXPECT_TRUE(mapping::markers_seen_elsewhere(m, b));  // no marker: nothing to keep
  markers::MarkerObservation seen;
  seen.id = 7;
  m.keyframe(b)->markers.push_back(seen);
  m.keyframe(c)->markers.push_back(seen);
  EXPECT_FALSE(mapping::markers_seen_elsewhere(m, b));  // c alone would be left
  m.keyframe(a)->markers.push_back(seen);
  EXPECT_TRUE(mapping::markers_seen_elsewhere(m, b));
  seen.id = 8;  // a second marker that only b sees
  m.keyframe(b)->markers.push_back(seen);
  EXPECT_FALSE(mapping::markers_seen_elsewhere(m, b));
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
  EXPECT_GT(s.mapping.keyframes_culled, 0);  // 27 of 35 on 2026-11-30
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
