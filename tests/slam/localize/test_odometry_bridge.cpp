// The localizer's odometry bridge on the fixture's twin room walk (localize_fixture.hpp): frames
// built as tracking builds them, bridged from a frame at its mapped pose without the map, and
// compared with the poses SLAM gave the same frames.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "slam/core/error.hpp"
#include "slam/localize/odometry_bridge.hpp"
#include "tests/slam/localize/localize_fixture.hpp"
#include "tests/slam/support/pipeline.hpp"

namespace coloc::slam::localize {
namespace {

using test::angle_deg;
using test::fixture;

class Walk {
 public:
  Walk()
      : settings_(settings::load_settings(fixture().sequence / "camera.yaml")),
        inputs_(test_support::tracker_inputs(settings_)),
        extractor_(inputs_.extractor) {
    dataset::SequenceOptions so;
    so.depth_scale = settings_.depth->depth_map_factor;
    sequence_ = dataset::open_sequence(fixture().sequence, so);
  }

  // Frame i with its features and keypoint depths, no pose: what the localizer's tracker holds.
  frame::Frame frame(std::size_t i) {
    const dataset::Frame f = sequence_->frame(i);
    cv::Mat grey;
    cv::cvtColor(f.color, grey, cv::COLOR_BGR2GRAY);
    return {FrameId(i), f.timestamp, extractor_.extract(grey, &inputs_.camera), f.depth,
            inputs_.geometry};
  }

  // cam_from_world SLAM gave frame i while mapping.
  SE3 mapped(std::size_t i) const {
    const double t = sequence_->timestamp(i);
    for (const auto& p : fixture().mapped)
      if (std::abs(p.timestamp - t) < 1e-4) return p.world_from_cam.inverse();
    ADD_FAILURE() << "frame " << i << " has no mapped pose";
    return {};
  }

 private:
  settings::Settings settings_;
  test_support::TrackerInputs inputs_;
  features::OrbExtractor extractor_;
  std::unique_ptr<dataset::Sequence> sequence_;
};

double position_error(const SE3& a_cam_from_world, const SE3& b_cam_from_world) {
  return (a_cam_from_world.inverse().translation() - b_cam_from_world.inverse().translation())
      .norm();
}

// One second of the walk (30 frames) carried on from one anchor, frame to frame: every frame
// gets a pose, and the drift stays within what a few seconds of bridging can afford.
TEST(OdometryBridge, FollowsTheWalkWithoutTheMap) {
  Walk walk;
  OdometryBridge bridge;
  const std::size_t first = 30, frames = 30;
  bridge.anchor(walk.frame(first), walk.mapped(first));
  double worst = 0.0, worst_deg = 0.0;
  for (std::size_t i = first + 1; i <= first + frames; ++i) {
    const auto pose = bridge.track(walk.frame(i));
    ASSERT_TRUE(pose) << "frame " << i;
    EXPECT_EQ(pose->bridged_frames, static_cast<int>(i - first));
    EXPECT_GE(pose->inliers, 30);
    worst = std::max(worst, position_error(pose->cam_from_world, walk.mapped(i)));
    worst_deg = std::max(worst_deg, angle_deg(pose->cam_from_world, walk.mapped(i)));
  }
  std::cout << "bridged " << frames << " frames: worst " << 1e3 * worst << " mm, " << worst_deg
            << " deg from the mapped poses\n";
  EXPECT_LT(worst, 0.02) << "metres";
  EXPECT_LT(worst_deg, 1.0);
}

// The bridge ends after max_frames in a row; a new anchor (the map found again) restarts it.
TEST(OdometryBridge, StopsAfterItsFrameBudgetAndRestartsFromANewAnchor) {
  Walk walk;
  OdometryBridgeOptions options;
  options.max_frames = 3;
  OdometryBridge bridge(options);
  EXPECT_FALSE(bridge.track(walk.frame(1))) << "no anchor yet";
  bridge.anchor(walk.frame(0), walk.mapped(0));
  for (std::size_t i = 1; i <= 3; ++i)
    ASSERT_TRUE(bridge.track(walk.frame(i))) << "frame " << i;
  EXPECT_FALSE(bridge.track(walk.frame(4)));
  bridge.anchor(walk.frame(4), walk.mapped(4));
  const auto pose = bridge.track(walk.frame(5));
  ASSERT_TRUE(pose);
  EXPECT_EQ(pose->bridged_frames, 1);
  EXPECT_LT(position_error(pose->cam_from_world, walk.mapped(5)), 0.01);
}

// A frame it cannot follow (the camera covered) ends the bridge: the next frame has no anchor,
// so the localizer reports lost rather than a pose from a stale one.
TEST(OdometryBridge, AFrameWithoutMatchesEndsTheBridge) {
  Walk walk;
  OdometryBridge bridge;
  bridge.anchor(walk.frame(10), walk.mapped(10));
  frame::Frame covered = walk.frame(11);
  covered = frame::Frame(FrameId(11), covered.timestamp, features::OrbFeatures{}, cv::Mat(),
                         std::make_shared<frame::FrameGeometry>(covered.geometry()));
  EXPECT_FALSE(bridge.track(covered));
  EXPECT_FALSE(bridge.has_anchor());
  EXPECT_FALSE(bridge.track(walk.frame(12)));
}

TEST(OdometryBridge, OptionsNameTheInvalidField) {
  OdometryBridgeOptions o;
  o.min_inliers = 5;
  EXPECT_THROW(o.check(), Error);
  o = {};
  o.max_frames = -1;
  EXPECT_THROW(OdometryBridge{o}, Error);
  o = {};
  o.max_frames = 0;  // off: never a pose
  OdometryBridge off(o);
  Walk walk;
  off.anchor(walk.frame(0), walk.mapped(0));
  EXPECT_FALSE(off.track(walk.frame(1)));
}

}  // namespace
}  // namespace coloc::slam::localize
