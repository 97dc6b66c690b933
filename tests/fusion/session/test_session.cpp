// The session core without sockets: one participant mapped through its calibration (checked
// against numbers worked out by hand), controllers, drift correction, stale users, hot reload,
// the localized anchor and the counters of inputs that are not used.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "fusion/session/session.hpp"
#include "session_fixtures.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::fusion::session {
namespace {

using testing::pose;

PoseMessage message(double time, int sequence, const SE3& p) {
  return PoseMessage::from_pose(time, sequence, 1, p);
}

// world_from_camera: yaw 90 deg, at (1, 2, 0). vive's vr_from_camera: camera 1 m above the VR
// origin, same axes. quest's: camera at (0, -3, 0) of its tracking space, yawed -90 deg.
struct TwoUsers : ::testing::Test {
  std::filesystem::path dir = coloc::testing::temp_dir("session_core");
  SE3 world_from_camera = pose(std::numbers::pi / 2, {1, 2, 0});
  SE3 vive_from_camera = pose(0.0, {0, 0, 1});
  SE3 quest_from_camera = pose(-std::numbers::pi / 2, {0, -3, 0});
  Session session{
      testing::two_user_config(dir, world_from_camera, vive_from_camera, quest_from_camera)};
  std::vector<Output> out;
};

TEST_F(TwoUsers, HeadMappedThroughTheCalibrationAsWorkedOutByHand) {
  // Head at (1, 0, 1.5) in vive's space, no rotation. In the camera frame (camera at z = 1 of
  // the VR space, same axes): (1, 0, 0.5). Rotated by yaw 90 deg: (0, 1, 0.5); plus (1, 2, 0):
  // (1, 3, 0.5). Its rotation: the camera's yaw, 90 deg about z.
  session.push_head("vive", message(10.0, 1, pose(0.0, {1, 0, 1.5})), 0.0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].address, "/coloc/users/vive/head");
  EXPECT_DOUBLE_EQ(out[0].pose.time, 10.0);
  EXPECT_EQ(out[0].pose.state, static_cast<int>(UserState::kCalibrated));
  EXPECT_NEAR((out[0].pose.position - Eigen::Vector3d(1, 3, 0.5)).norm(), 0.0, 1e-12);
  const Eigen::Quaterniond q = out[0].pose.orientation;
  EXPECT_NEAR(std::abs(q.w()), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(std::abs(q.z()), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(q.w() * q.z(), 0.5, 1e-12);  // +90 deg, not -90

  // quest: head at (0, -1, 1.6) of its space, yawed +90 deg. Camera at (0, -3, 0) yawed -90:
  // camera_from_vr maps (0, -1, 1.6) -> R(+90) * ((0, -1, 1.6) - (0, -3, 0)) = R(+90) * (0, 2,
  // 1.6) = (-2, 0, 1.6); the world: R(+90) * (-2, 0, 1.6) + (1, 2, 0) = (0, -2, 1.6) + (1, 2,
  // 0) = (1, 0, 1.6). Rotation: 90 + 90 + 90 = 270 deg = -90 deg.
  out.clear();
  session.push_head("quest", message(3.0, 7, pose(std::numbers::pi / 2, {0, -1, 1.6})), 0.0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].address, "/coloc/users/quest/head");
  EXPECT_NEAR((out[0].pose.position - Eigen::Vector3d(1, 0, 1.6)).norm(), 0.0, 1e-12);
  const Eigen::Quaterniond r = out[0].pose.orientation;
  EXPECT_NEAR(r.w() * r.z(), -0.5, 1e-12);
}

TEST_F(TwoUsers, ControllersShareTheirSystemsPlacement) {
  session.push_controller("vive", 1, message(1.0, 0, pose(0.0, {0, 0, 1})), 0.0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].address, "/coloc/users/vive/controller/1");
  // The controller sits at the camera's position: the world pose of the camera.
  EXPECT_NEAR((out[0].pose.position - world_from_camera.translation()).norm(), 0.0, 1e-12);
  session.push_controller("vive", 2, message(1.0, 0, SE3()), 0.0, out);  // only 0 and 1
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(session.stats().bad_controller, 1u);
}

TEST_F(TwoUsers, UnknownOutOfOrderAndCountedNeverFatal) {
  session.push_head("nobody", message(1.0, 1, SE3()), 0.0, out);
  session.push_global("nobody", message(1.0, 1, SE3()), 0.0);
  session.push_head("vive", message(1.0, 5, SE3()), 0.0, out);
  session.push_head("vive", message(0.9, 4, SE3()), 0.0, out);  // older sequence
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(session.stats().unknown_participant, 2u);
  EXPECT_EQ(session.stats().out_of_order, 1u);
  EXPECT_FALSE(session.current("nobody", out));
}

// Issue 17's class 1 for the session: one message stamped far in the future (or with a jumped
// sequence number) must not freeze a user's stream; a restarted sender is taken back.
TEST_F(TwoUsers, OneAbsurdMessageDoesNotFreezeAUser) {
  session.push_head("vive", message(1.0, 1, SE3()), 0.0, out);
  session.push_head("vive", message(1e9, 2, SE3()), 0.01, out);      // far future
  session.push_head("vive", message(1.02, 5000, SE3()), 0.02, out);  // sequence jump
  EXPECT_EQ(session.stats().implausible, 2u);
  out.clear();
  for (int i = 0; i < 3; ++i)
    session.push_head("vive", message(1.03 + 0.01 * i, 2 + i, SE3()), 0.03 + 0.01 * i, out);
  EXPECT_EQ(out.size(), 3u) << "the real stream goes on";
  out.clear();
  for (int i = 0; i < 6; ++i)  // restarted sender: sequence and clock from the beginning
    session.push_head("vive", message(0.1 + 0.01 * i, 1 + i, SE3()), 0.1 + 0.01 * i, out);
  EXPECT_GE(out.size(), 1u) << "re-anchored after a few consistent messages";
}

TEST_F(TwoUsers, StaleAfterTimeoutNotFrozen) {
  session.push_head("vive", message(1.0, 1, pose(0.0, {1, 0, 1.5})), 100.0, out);
  session.push_controller("vive", 0, message(1.0, 1, SE3()), 100.2, out);
  EXPECT_DOUBLE_EQ(session.next_deadline(), 100.5);
  out.clear();
  session.tick(100.4, out);
  EXPECT_TRUE(out.empty());
  session.tick(100.55, out);  // the head is stale, the controller not yet
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].address, "/coloc/users/vive/head");
  EXPECT_EQ(out[0].pose.state, static_cast<int>(UserState::kStale));
  EXPECT_NEAR((out[0].pose.position - Eigen::Vector3d(1, 3, 0.5)).norm(), 0.0, 1e-12);
  EXPECT_TRUE(session.snapshot("vive").stale);
  session.tick(100.8, out);  // the controller; the head is not announced again
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].address, "/coloc/users/vive/controller/0");
  session.tick(105.0, out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(session.stats().stale_events, 2u);
  // A reply says stale too; a new pose makes the user live again.
  std::vector<Output> now;
  ASSERT_TRUE(session.current("vive", now));
  ASSERT_EQ(now.size(), 2u);
  EXPECT_EQ(now[0].pose.state, static_cast<int>(UserState::kStale));
  session.push_head("vive", message(6.0, 2, pose(0.0, {1, 0, 1.5})), 106.0, out);
  EXPECT_EQ(out.back().pose.state, static_cast<int>(UserState::kCalibrated));
  EXPECT_FALSE(session.snapshot("vive").stale);
}

TEST_F(TwoUsers, HotReloadReplacesOneCalibration) {
  session.push_head("quest", message(1.0, 1, pose(0.0, {0, 0, 1.6})), 0.0, out);
  const SE3 before = out.back().pose.pose();
  // A new registration: quest's camera 5 cm further along its x. The user moves by 5 cm.
  testing::write_calibration(dir / "b.yaml", quest_from_camera * pose(0.0, {0.05, 0, 0}));
  const ReloadReport r = session.reload("quest");
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_NEAR(r.translation, 0.05, 1e-9);
  EXPECT_EQ(session.snapshot("quest").calibration_version, 1u);
  session.push_head("quest", message(1.1, 2, pose(0.0, {0, 0, 1.6})), 0.1, out);
  EXPECT_NEAR(translation_distance(before, out.back().pose.pose()), 0.05, 1e-6);
  // vive is untouched.
  EXPECT_EQ(session.snapshot("vive").calibration_version, 0u);

  // A broken file: the old calibration stays, the failure is counted.
  std::ofstream(dir / "b.yaml") << "vr_from_camera: [1, 2]\n";
  const ReloadReport bad = session.reload("quest");
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("b.yaml"), std::string::npos);
  session.push_head("quest", message(1.2, 3, pose(0.0, {0, 0, 1.6})), 0.2, out);
  EXPECT_NEAR(translation_distance(before, out.back().pose.pose()), 0.05, 1e-6);
  EXPECT_EQ(session.stats().reloads, 1u);
  EXPECT_EQ(session.stats().reload_failures, 1u);
  EXPECT_EQ(session.participant_by_calibration(dir / "b.yaml")->id, "quest");
}

TEST_F(TwoUsers, GlobalPosesDriftCorrectHeadAndControllers) {
  // The true head is 0.3 m further along world x than the calibration places it (the system
  // drifted). Global poses say so; the fuser takes it up and the controllers move with it.
  const SE3 drift = pose(0.0, {0.3, 0, 0});
  for (int i = 0; i < 200; ++i) {
    const double t = 1.0 + i / 90.0;
    const SE3 vr_from_head = pose(0.01 * i, {0.01 * i, 0, 1.6});
    session.push_head("vive", message(t, i, vr_from_head), t, out);
    if (i % 4 == 2) {
      const SE3 calibrated = world_from_camera * vive_from_camera.inverse() * vr_from_head;
      session.push_global("vive", message(t, i, drift * calibrated), t);
    }
  }
  const Output head = out.back();
  EXPECT_EQ(head.pose.state, static_cast<int>(UserState::kCorrected));
  const SE3 vr_from_head = pose(0.01 * 199, {1.99, 0, 1.6});
  const SE3 truth = drift * world_from_camera * vive_from_camera.inverse() * vr_from_head;
  EXPECT_LT(translation_distance(head.pose.pose(), truth), 0.01);
  session.push_controller("vive", 0, message(3.3, 0, SE3()), 3.3, out);
  const SE3 controller_truth = drift * world_from_camera * vive_from_camera.inverse();
  EXPECT_LT(translation_distance(out.back().pose.pose(), controller_truth), 0.01);
  EXPECT_EQ(out.back().pose.state, static_cast<int>(UserState::kCorrected));
  EXPECT_GT(session.stats().global_poses, 40u);
}

TEST(SessionAnchor, LocalizedCameraPlacesParticipantsOnceAveraged) {
  const auto dir = coloc::testing::temp_dir("session_anchor");
  testing::write_calibration(dir / "a.yaml", SE3());
  std::ofstream(dir / "s.yaml") << "anchor:\n  localize: {port: 9555, poses: 4}\n"
                                   "participants:\n  - {id: a, kind: mr, calibration: a.yaml}\n";
  Session session(read_session_config(dir / "s.yaml"));
  std::vector<Output> out;
  session.push_head("a", message(1.0, 1, SE3()), 0.0, out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(session.stats().waiting_for_anchor, 1u);
  for (int i = 0; i < 4; ++i) {
    // Localizer noise of +-1 cm around (2, 0, 1): the mean is exact.
    session.push_anchor(message(i, i, pose(0.0, {2.0 + (i % 2 ? 0.01 : -0.01), 0, 1})));
  }
  ASSERT_TRUE(session.anchored());
  session.push_head("a", message(2.0, 2, SE3()), 0.0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR((out[0].pose.position - Eigen::Vector3d(2, 0, 1)).norm(), 0.0, 1e-9);
}

TEST(SessionAnchor, UnreadableCalibrationNamesTheParticipant) {
  const auto dir = coloc::testing::temp_dir("session_bad_calibration");
  std::ofstream(dir / "s.yaml") << "anchor:\n  world_from_camera: [0, 0, 0, 0, 0, 0, 1]\n"
                                   "participants:\n  - {id: a, kind: vr, calibration: none.yaml}\n";
  try {
    Session session(read_session_config(dir / "s.yaml"));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "participants[0].calibration");
    EXPECT_NE(std::string(e.what()).find("'a'"), std::string::npos);
  }
}

}  // namespace
}  // namespace coloc::fusion::session
