// Rolling-shutter compensation changed in keyframes already in the map: keyframes are
// compensated again (a new readout, or a first rate) and each point turns with its reference
// keyframe's keypoint.
#include <gtest/gtest.h>

#include <map>

#include "slam/frame/rolling_shutter.hpp"
#include "slam/map/shutter.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::map {
namespace {

// A keyframe whose keypoints spread over the rows (the middle row does not move), turning at
// `rate` while its rows were read, compensated so far with a readout of 0; a point per keypoint.
KeyframeId add_turning_keyframe(Map& m, const Eigen::Vector3d& rate, double x) {
  Keyframe kf = test_support::row_keyframe(m, 12, {x, 0.0, 0.0});
  for (std::size_t i = 0; i < kf.frame.size(); ++i) {
    auto& kp = kf.frame.features.keypoints[i];
    kp.y = kp.uy = static_cast<float>(20 + 40 * i);
  }
  kf.frame.compensate_rolling_shutter(rate, 480, 0.0);  // records the rate only
  const KeyframeId id = m.add_keyframe(std::move(kf)).id;
  for (std::uint32_t i = 0; i < 12; ++i)
    m.add_point(m.keyframe(id)->frame.unproject_world(i), id, i);
  return id;
}

// Each point projects onto its reference keyframe's (compensated) keypoint, at its depth.
void expect_points_on_their_keypoints(const Map& m) {
  for (const auto& [id, p] : m.points()) {
    const frame::Frame& ref = m.keyframe(p.reference)->frame;
    const std::uint32_t i = p.observations.at(p.reference);
    const Eigen::Vector3d pc = ref.cam_from_world * p.position;
    EXPECT_NEAR(pc.z(), ref.depth[i], 1e-6) << "point " << id.value();
    EXPECT_LT((ref.geometry().project(pc) - ref.pixel(i)).norm(), 1e-3) << "point " << id.value();
  }
}

TEST(MapShutter, PointsFollowTheirReferenceKeyframesKeypoints) {
  Map m;
  const Eigen::Vector3d rate(0.7, 2.0, -0.4);
  const KeyframeId turning = add_turning_keyframe(m, rate, 0.0);
  const KeyframeId still = add_turning_keyframe(m, Eigen::Vector3d::Zero(), 0.5);
  const features::OrbFeatures before = m.keyframe(turning)->frame.features;
  std::map<MapPointId, Eigen::Vector3d> positions;
  for (const auto& [id, p] : m.points())
    positions[id] = p.position;

  set_map_readout(m, 0.02);
  const frame::Frame& f = m.keyframe(turning)->frame;
  EXPECT_EQ(f.shutter_readout, 0.02);
  // The keypoints moved as a 20 ms compensation moves them.
  features::OrbFeatures expected = before;
  const auto& g = f.geometry();
  frame::compensate_rolling_shutter(expected, {0.02, 480}, rate, g.fx, g.fy, g.cx, g.cy);
  double moved = 0.0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    EXPECT_NEAR(f.features.keypoints[i].ux, expected.keypoints[i].ux, 1e-3) << i;
    EXPECT_NEAR(f.features.keypoints[i].uy, expected.keypoints[i].uy, 1e-3) << i;
    moved = std::max(moved, double{std::abs(f.features.keypoints[i].ux - before.keypoints[i].ux)});
    EXPECT_NEAR(f.u_right[i], f.features.keypoints[i].ux - g.bf / f.depth[i], 1e-3);
  }
  EXPECT_GT(moved, 5.0);  // 2 rad/s over 10 ms at the top and bottom rows: ~10 px
  // Each point projects onto its keypoint again; the still keyframe's stay put.
  expect_points_on_their_keypoints(m);
  for (const auto& [id, p] : m.points()) {
    if (p.reference == still) {
      EXPECT_EQ(p.position, positions[id]);
    }
  }
  // Back to 0: everything returns.
  set_map_readout(m, 0.0);
  for (const auto& [id, p] : m.points())
    EXPECT_LT((p.position - positions[id]).norm(), 1e-9);
}

// The first keyframe of a map is made before any rate is known; the frame after it gives one.
TEST(MapShutter, AKeyframeWithoutRateTakesOneAndItsPointsFollow) {
  Map m;
  const KeyframeId first = add_turning_keyframe(m, Eigen::Vector3d::Zero(), 0.0);
  const KeyframeId other = add_turning_keyframe(m, Eigen::Vector3d(0.0, 1.0, 0.0), 0.5);
  const features::OrbFeatures before = m.keyframe(first)->frame.features;
  std::map<MapPointId, Eigen::Vector3d> positions;
  for (const auto& [id, p] : m.points())
    positions[id] = p.position;

  const Eigen::Vector3d rate(0.3, -1.5, 0.2);
  set_keyframe_shutter_rate(m, first, rate, 480, 0.02);
  const frame::Frame& f = m.keyframe(first)->frame;
  EXPECT_EQ(f.shutter_rate, rate);
  EXPECT_EQ(f.shutter_readout, 0.02);
  features::OrbFeatures expected = before;
  const auto& g = f.geometry();
  frame::compensate_rolling_shutter(expected, {0.02, 480}, rate, g.fx, g.fy, g.cx, g.cy);
  for (std::size_t i = 0; i < f.size(); ++i) {
    EXPECT_NEAR(f.features.keypoints[i].ux, expected.keypoints[i].ux, 1e-3) << i;
    EXPECT_NEAR(f.features.keypoints[i].uy, expected.keypoints[i].uy, 1e-3) << i;
  }
  expect_points_on_their_keypoints(m);
  for (const auto& [id, p] : m.points()) {
    if (p.reference == other) {
      EXPECT_EQ(p.position, positions[id]);  // another keyframe's points stay
    } else {
      EXPECT_GT((p.position - positions[id]).norm(), 1e-4);
    }
  }
  // Once it has a rate, it keeps it: this is not how a rate is changed.
  const features::OrbFeatures compensated = f.features;
  set_keyframe_shutter_rate(m, first, Eigen::Vector3d(1.0, 0.0, 0.0), 480, 0.02);
  EXPECT_EQ(f.shutter_rate, rate);
  EXPECT_EQ(f.features.keypoints[0].ux, compensated.keypoints[0].ux);
}

}  // namespace
}  // namespace coloc::slam::map
