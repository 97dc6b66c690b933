// The session description: the three ways to place the anchor camera, defaults, and errors that
// name the file, line and field.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

#include "fusion/session/config.hpp"
#include "session_fixtures.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::fusion::session {
namespace {

const char* kPose16 = "[1, 0, 0, 1,  0, 1, 0, 2,  0, 0, 1, 0.5,  0, 0, 0, 1]";

SessionConfig parse(const std::string& text) {
  return parse_session_config(text, "/tmp/site/session.yaml");
}

// The error's field, file and line, or the test fails.
Error parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return Error("none");
}

std::string participants() {
  return "participants:\n"
         "  - id: vive\n    kind: vr\n    calibration: vive.yaml\n    port: 9101\n"
         "  - id: tablet\n    kind: ar\n    system: iPad ARKit\n    calibration: /abs/tablet.yaml\n"
         "    controllers: 0\n    drift_correction: false\n";
}

TEST(SessionConfig, FixedAnchorAndParticipants) {
  const SessionConfig c = parse(std::string("anchor:\n  camera: floor-cam\n  world_from_camera: ") +
                                kPose16 + "\nstale_after: 0.25\n" + participants());
  EXPECT_EQ(c.anchor.mode, AnchorMode::kFixed);
  EXPECT_EQ(c.anchor.camera, "floor-cam");
  EXPECT_TRUE(c.anchor.world_from_camera.translation().isApprox(Eigen::Vector3d(1, 2, 0.5)));
  EXPECT_DOUBLE_EQ(c.stale_after, 0.25);
  ASSERT_EQ(c.participants.size(), 2u);
  EXPECT_EQ(c.participants[0].id, "vive");
  EXPECT_EQ(c.participants[0].kind, ParticipantKind::kVr);
  EXPECT_EQ(c.participants[0].calibration, std::filesystem::path("/tmp/site/vive.yaml"));
  EXPECT_EQ(c.participants[0].port, 9101);
  EXPECT_EQ(c.participants[0].controllers, 2);  // default
  EXPECT_TRUE(c.participants[0].drift_correction);
  EXPECT_EQ(c.participants[1].kind, ParticipantKind::kAr);
  EXPECT_EQ(c.participants[1].calibration, std::filesystem::path("/abs/tablet.yaml"));
  EXPECT_EQ(c.participants[1].controllers, 0);
  EXPECT_FALSE(c.participants[1].drift_correction);
  EXPECT_EQ(c.find("tablet"), &c.participants[1]);
  EXPECT_EQ(c.find("nobody"), nullptr);
}

TEST(SessionConfig, MarkerOnTheFloorGivesWorldFromCamera) {
  // Marker 2 m in front of the camera (camera_from_marker), marker at (5, 0, 0) in the world.
  const SessionConfig c = parse(
      "anchor:\n  world_from_marker: [5, 0, 0, 0, 0, 0, 1]\n"
      "  camera_from_marker: [0, 0, 2, 0, 0, 0, 1]\n" +
      participants());
  EXPECT_TRUE(c.anchor.world_from_camera.translation().isApprox(Eigen::Vector3d(5, 0, -2)));
}

TEST(SessionConfig, LocalizedAnchor) {
  const SessionConfig c = parse("anchor:\n  localize: {port: 9200, poses: 10}\n" + participants());
  EXPECT_EQ(c.anchor.mode, AnchorMode::kLocalize);
  EXPECT_EQ(c.anchor.localize_port, 9200);
  EXPECT_EQ(c.anchor.localize_poses, 10);
}

TEST(SessionConfig, ErrorsNameFileLineAndField) {
  const std::string anchor = std::string("anchor:\n  world_from_camera: ") + kPose16 + "\n";
  Error e = parse_error(anchor + "stale_aftr: 1\n" + participants());
  EXPECT_EQ(e.context().field, "stale_aftr");
  EXPECT_EQ(e.context().file, "/tmp/site/session.yaml");
  EXPECT_EQ(e.context().line, 3);
  EXPECT_NE(std::string(e.what()).find("unknown key"), std::string::npos);

  e = parse_error(anchor + "participants:\n  - {id: a, kind: vr}\n");
  EXPECT_EQ(e.context().field, "participants[0].calibration");
  e = parse_error(anchor + "participants:\n  - {id: a, kind: xr, calibration: a.yaml}\n");
  EXPECT_EQ(e.context().field, "participants[0].kind");
  e = parse_error(anchor +
                  "participants:\n  - {id: a, kind: vr, calibration: a.yaml}\n"
                  "  - {id: a, kind: ar, calibration: b.yaml}\n");
  EXPECT_EQ(e.context().field, "participants[1].id");
  e = parse_error(anchor + "participants:\n  - {id: 'a b', kind: vr, calibration: a.yaml}\n");
  EXPECT_EQ(e.context().field, "participants[0].id");
  e = parse_error(anchor +
                  "participants:\n  - {id: a, kind: vr, calibration: a.yaml, port: 9}\n"
                  "  - {id: b, kind: vr, calibration: b.yaml, port: 9}\n");
  EXPECT_EQ(e.context().field, "participants[1].port");
  e = parse_error(anchor +
                  "participants:\n  - {id: a, kind: vr, calibration: a.yaml, "
                  "controllers: many}\n");
  EXPECT_EQ(e.context().field, "participants[0].controllers");
  e = parse_error("anchor:\n  world_from_camera: [1, 2, 3]\n" + participants());
  EXPECT_EQ(e.context().field, "anchor.world_from_camera");
  e = parse_error("anchor:\n  world_from_camera: [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n" +
                  participants());
  EXPECT_NE(std::string(e.what()).find("rigid"), std::string::npos);
  e = parse_error("anchor:\n  camera: c\n" + participants());
  EXPECT_EQ(e.context().field, "anchor");
  e = parse_error(anchor + "participants: []\n");
  EXPECT_EQ(e.context().field, "participants");
  e = parse_error("anchor: [unclosed\n");
  EXPECT_TRUE(e.context().line.has_value());
}

TEST(SessionConfig, ReadsAFileAndResolvesCalibrationsNextToIt) {
  const auto dir = coloc::testing::temp_dir("session_config_file");
  const SessionConfig c =
      testing::two_user_config(dir, SE3(), testing::pose(0.3, {1, 0, 0}), SE3(), 9301);
  EXPECT_EQ(c.participants[0].calibration, dir / "a.yaml");
  EXPECT_EQ(c.participants[0].port, 9301);
  EXPECT_THROW(read_session_config(dir / "missing.yaml"), Error);
}

// A FIFO (which hung `coloc session check` and `session --config`) or a directory is an error
// saying what the path is, at once.
TEST(SessionConfig, FifoAndDirectoryAreNamedNotRead) {
  const auto dir = coloc::testing::temp_dir("session_config_fifo");
  ASSERT_EQ(::mkfifo((dir / "fifo.yaml").c_str(), 0600), 0);
  try {
    read_session_config(dir / "fifo.yaml");
    FAIL() << "a FIFO was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is a FIFO"), std::string::npos) << e.what();
  }
  try {
    read_session_config(dir);
    FAIL() << "a directory was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
}

// An anchor pose that is not rigid is refused through the one rigid check of slam/core, the key
// named.
// yaml-cpp's conversion of a malformed flow map (found by scripts/fuzz_yaml) is an Error naming
// the file, not a YAML::Exception.
TEST(SessionConfig, WhatYamlCppThrowsIsAnErrorNamingTheFile) {
  const std::string text =
      "anchor:\n  world_from_camera: [1, 2, 0.5, 0, 0, 0.7071068, 0.7071068]\nparticipants:\n"
      "  - {id: vive, kin!ncho id: vdyaml}: ";
  try {
    parse_session_config(text, "fuzzed.yaml");
    FAIL() << "accepted";
  } catch (const coloc::Error& e) {
    EXPECT_EQ(e.context().file, "fuzzed.yaml") << e.what();
  }
}

TEST(SessionConfig, NonRigidAnchorPoseIsRefused) {
  const Error e = parse_error(
      "anchor:\n  world_from_camera: [1.2, 0, 0, 1,  0, 1.2, 0, 2,  0, 0, 1.2, 0.5,  0, 0, 0, "
      "1]\n" +
      participants());
  EXPECT_NE(e.message().find("not orthonormal"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("world_from_camera"), std::string::npos) << e.what();
}

}  // namespace
}  // namespace coloc::fusion::session
