#include <gtest/gtest.h>

#include <cmath>

#include "fusion/fuser.hpp"
#include "fusion/pose_buffer.hpp"

namespace coloc::fusion {
namespace {

// A head moving along x at 1 m/s while turning at 1 rad/s about z.
SE3 head_at(double t) {
  return SE3(SO3::from_axis_angle(Eigen::Vector3d::UnitZ(), t), Eigen::Vector3d(t, 0.0, 1.6));
}

TEST(PoseBuffer, InterpolatesBetweenSamples) {
  PoseBuffer buffer(2.0);
  for (int i = 0; i <= 90; ++i)
    ASSERT_TRUE(buffer.push(i / 90.0, head_at(i / 90.0)));
  EXPECT_FALSE(buffer.push(0.5, head_at(0.5)));  // out of order
  const auto mid = buffer.at(0.505);
  ASSERT_TRUE(mid.has_value());
  EXPECT_LT(translation_distance(*mid, head_at(0.505)), 1e-9);
  EXPECT_LT(rotation_distance(*mid, head_at(0.505)), 1e-9);
  EXPECT_FALSE(buffer.at(-0.1).has_value());
  EXPECT_FALSE(buffer.at(1.1, 0.02).has_value());
  EXPECT_TRUE(buffer.at(1.01, 0.02).has_value());
}

TEST(PoseBuffer, ForgetsOldPoses) {
  PoseBuffer buffer(0.5);
  for (int i = 0; i <= 180; ++i)
    buffer.push(i / 90.0, head_at(i / 90.0));
  EXPECT_FALSE(buffer.at(1.0).has_value());
  EXPECT_TRUE(buffer.at(1.8).has_value());
  EXPECT_LE(buffer.size(), 47u);
}

// Feeds headset poses at 90 Hz and global poses at 20 Hz that arrive `latency` seconds after
// their exposure; returns the final fused error against the truth (metres).
double run_latency_scenario(bool time_alignment, double latency) {
  const SE3 world_from_xr(SO3::from_axis_angle(Eigen::Vector3d::UnitZ(), 0.2),
                          Eigen::Vector3d(0.5, -0.3, 0.0));
  FuserOptions options;
  options.time_alignment = time_alignment;
  DriftFuser fuser(options);
  double next_global = 0.1;
  double error = 0.0;
  for (int i = 0; i < 90 * 10; ++i) {
    const double t = i / 90.0;
    // Global poses whose arrival time has come (exposure + latency <= now).
    while (next_global + latency <= t) {
      fuser.push_global_pose(next_global, world_from_xr * head_at(next_global));
      next_global += 0.05;
    }
    const FusedPose out = fuser.push_xr_pose(t, head_at(t));
    if (out.state == FusionState::kTracking) {
      error = translation_distance(out.world_from_head, world_from_xr * head_at(t));
    }
  }
  return error;
}

TEST(DriftFuser, TimeAlignmentRemovesTheLatencyArtefact) {
  // The headset has no drift here: any error is the latency artefact.
  const double aligned = run_latency_scenario(true, 0.05);
  const double paper = run_latency_scenario(false, 0.05);
  EXPECT_LT(aligned, 1e-3);
  EXPECT_GT(paper, 0.02);  // ~ 5 cm of false drift at 1 m/s with 50 ms latency
}

TEST(DriftFuser, OutputsHeadsetUntilFirstGlobalThenTracksThenHolds) {
  FuserOptions options;
  options.hold_after = 0.3;
  DriftFuser fuser(options);
  const SE3 d(SO3(), Eigen::Vector3d(1.0, 0.0, 0.0));
  FusedPose out = fuser.push_xr_pose(0.0, head_at(0.0));
  EXPECT_EQ(out.state, FusionState::kWaiting);
  EXPECT_LT(translation_distance(out.world_from_head, head_at(0.0)), 1e-12);

  fuser.push_xr_pose(0.01, head_at(0.01));
  EXPECT_EQ(fuser.push_global_pose(0.01, d * head_at(0.01)), GateDecision::kInitialized);
  out = fuser.push_xr_pose(0.02, head_at(0.02));
  EXPECT_EQ(out.state, FusionState::kTracking);
  EXPECT_LT(translation_distance(out.world_from_head, d * head_at(0.02)), 1e-9);

  out = fuser.push_xr_pose(0.5, head_at(0.5));  // no global pose for 0.49 s
  EXPECT_EQ(out.state, FusionState::kHolding);
  EXPECT_LT(translation_distance(out.world_from_head, d * head_at(0.5)), 1e-9);  // D held

  EXPECT_EQ(fuser.push_global_pose(0.49, d * head_at(0.49)), GateDecision::kAccepted);
  EXPECT_EQ(fuser.push_xr_pose(0.51, head_at(0.51)).state, FusionState::kTracking);
}

TEST(DriftFuser, CountsUnusableInput) {
  DriftFuser fuser;
  fuser.push_global_pose(0.0, head_at(0.0));  // no headset pose yet
  fuser.push_xr_pose(1.0, head_at(1.0));
  fuser.push_xr_pose(0.5, head_at(0.5));  // out of order
  fuser.push_global_pose(1.0, head_at(1.0), TrackingState::kLost);
  fuser.push_global_pose(1.0, head_at(1.0));
  fuser.push_global_pose(0.9, head_at(0.9));  // older than the previous global pose
  const FuserStats& s = fuser.stats();
  EXPECT_EQ(s.global_poses, 4u);
  EXPECT_EQ(s.unaligned, 1u);
  EXPECT_EQ(s.lost, 1u);
  EXPECT_EQ(s.initialized, 1u);
  EXPECT_EQ(s.out_of_order, 2u);
  EXPECT_EQ(s.xr_poses, 1u);
}

// A pose the localizer carried on by visual odometry outside its map drifts like the headset:
// it neither starts nor moves the correction, and the wire's numbers map to the states.
TEST(DriftFuser, IgnoresOdometryPoses) {
  DriftFuser fuser;
  fuser.push_xr_pose(0.0, head_at(0.0));
  fuser.push_xr_pose(0.1, head_at(0.1));
  const SE3 off(SO3(), Eigen::Vector3d(0.5, 0.0, 0.0));
  EXPECT_EQ(fuser.push_global_pose(0.05, off * head_at(0.05), TrackingState::kOdometry),
            GateDecision::kRejected);
  EXPECT_EQ(fuser.stats().odometry, 1u);
  EXPECT_EQ(fuser.stats().lost, 0u);
  EXPECT_EQ(fuser.push_xr_pose(0.11, head_at(0.11)).state, FusionState::kWaiting);
  EXPECT_EQ(tracking_state_from_wire(0), TrackingState::kLost);
  EXPECT_EQ(tracking_state_from_wire(1), TrackingState::kTracking);
  EXPECT_EQ(tracking_state_from_wire(2), TrackingState::kRelocalized);
  EXPECT_EQ(tracking_state_from_wire(3), TrackingState::kOdometry);
  EXPECT_EQ(tracking_state_from_wire(9), TrackingState::kTracking);  // a newer sender's state
}

TEST(DriftFuser, GatingKeepsTheUserInPlace) {
  DriftFuser fuser;
  for (int i = 0; i < 200; ++i) {
    const double t = i / 90.0;
    fuser.push_xr_pose(t, head_at(t));
    if (i % 4 == 0) fuser.push_global_pose(t, head_at(t));
  }
  const SE3 bad(SO3(), head_at(200 / 90.0).translation() + Eigen::Vector3d(0.8, 0.0, 0.0));
  fuser.push_xr_pose(200 / 90.0, head_at(200 / 90.0));
  EXPECT_EQ(fuser.push_global_pose(200 / 90.0, SE3(head_at(200 / 90.0).so3(), bad.translation())),
            GateDecision::kRejected);
  const FusedPose out = fuser.push_xr_pose(201 / 90.0, head_at(201 / 90.0));
  EXPECT_LT(translation_distance(out.world_from_head, head_at(201 / 90.0)), 1e-6);
  EXPECT_EQ(fuser.stats().rejected, 1u);
}

TEST(DriftFuser, RateLimitBoundsTheCorrectionSpeed) {
  FuserOptions options;
  options.filter.gating = false;
  options.filter.reset_after_rejections = 1000;
  options.max_correction_speed = 0.05;  // 5 cm/s
  options.max_correction_rate = 0.05;
  DriftFuser fuser(options);
  const SE3 head(SO3(), Eigen::Vector3d(0.0, 0.0, 1.6));
  fuser.push_xr_pose(0.0, head);
  fuser.push_global_pose(0.0, head);  // D = identity
  // The drift jumps by 1 m; the filter follows, the user sees at most 5 cm/s of it.
  const SE3 shifted(SO3(), Eigen::Vector3d(1.0, 0.0, 1.6));
  Eigen::Vector3d previous = head.translation();
  for (int i = 1; i < 900; ++i) {
    const double t = i / 90.0;
    if (i % 4 == 0) fuser.push_global_pose(t, shifted);
    const FusedPose out = fuser.push_xr_pose(t, head);
    const double step = (out.world_from_head.translation() - previous).norm();
    EXPECT_LE(step, 0.05 / 90.0 + 1e-12) << i;
    previous = out.world_from_head.translation();
  }
  EXPECT_GT(translation_distance(fuser.filtered_drift(), fuser.applied_drift()), 0.1);
  const SE3 limited = step_toward(SE3(), shifted, 0.1, 0.0);
  EXPECT_NEAR(limited.translation().norm(), 0.1, 1e-12);
}

// Global poses stop for 30 s while the headset drifts by 10 cm; when they come back the held D
// is 10 cm off. The filter takes the change up (no rejections, no re-initialization jump) and
// converges within a second.
TEST(DriftFuser, TakesUpDriftThatAccumulatedWhileHolding) {
  DriftFuser fuser;
  const SE3 head(SO3(), Eigen::Vector3d(0.0, 0.0, 1.6));
  const SE3 moved(SO3(), Eigen::Vector3d(0.1, 0.0, 1.6));  // world pose after the drift
  double t = 0.0;
  for (int i = 0; i < 10 * 90; ++i, t += 1.0 / 90.0) {
    fuser.push_xr_pose(t, head);
    if (i % 4 == 0) fuser.push_global_pose(t, head);
  }
  t += 30.0;
  EXPECT_EQ(fuser.push_xr_pose(t, head).state, FusionState::kHolding);
  double error = 1.0;
  for (int i = 0; i < 90; ++i, t += 1.0 / 90.0) {
    if (i % 4 == 0) {
      EXPECT_NE(fuser.push_global_pose(t - 0.005, moved), GateDecision::kRejected) << i;
    }
    error = translation_distance(fuser.push_xr_pose(t, head).world_from_head, moved);
  }
  EXPECT_LT(error, 0.01);
  EXPECT_EQ(fuser.stats().rejected, 0u);
  EXPECT_EQ(fuser.stats().initialized, 1u);
}

}  // namespace
}  // namespace coloc::fusion
