// Text formats (parse errors name the line) and session guidance.

#include <gtest/gtest.h>

#include <fstream>

#include "registration/handeye/guidance.hpp"
#include "registration/handeye/io.hpp"
#include "registration/handeye/simulate.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::handeye {
namespace {

void write(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

TEST(HandeyeIo, PairsRoundTripAndSolve) {
  const auto dir = testing::temp_dir("handeye_io");
  SimulationOptions o;
  o.seed = 8;
  const Simulation sim = simulate(o);
  std::vector<TimedRegistration> timed;
  for (std::size_t k = 0; k < sim.registrations.size(); ++k) {
    timed.push_back({0.5 * k, sim.registrations[k]});
  }
  write_pairs_file(dir / "pairs.csv", timed);
  const auto back = read_pairs_file(dir / "pairs.csv");
  ASSERT_EQ(back.size(), timed.size());
  for (std::size_t k = 0; k < back.size(); ++k) {
    EXPECT_LT(translation_distance(back[k].registration.camera_from_marker,
                                   timed[k].registration.camera_from_marker),
              1e-9);
    EXPECT_LT(rotation_distance(back[k].registration.vr_from_device,
                                timed[k].registration.vr_from_device),
              1e-9);
  }
}

TEST(HandeyeIo, DeviceAndMarkerCsvMatchedByTime) {
  const auto dir = testing::temp_dir("handeye_match");
  write(dir / "device.csv",
        "t,tx,ty,tz,qx,qy,qz,qw\n0.00,1,0,0,0,0,0,1\n1.00,2,0,0,0,0,0,1\n2.00,3,0,0,0,0,0,1\n");
  write(dir / "marker.csv", "# PnP\n1.004 0 0 2 0 0 0 1\n0.3 0 0 1 0 0 0 1\n2.2 0 0 3 0 0 0 1\n");
  const auto device = read_pose_csv(dir / "device.csv");
  const auto marker = read_pose_csv(dir / "marker.csv");
  ASSERT_EQ(device.size(), 3u);
  const auto matched = match_by_time(device, marker, 0.02);
  ASSERT_EQ(matched.size(), 1u);
  EXPECT_DOUBLE_EQ(matched[0].t, 1.0);
  EXPECT_DOUBLE_EQ(matched[0].registration.camera_from_marker.translation().z(), 2.0);
}

TEST(HandeyeIo, ParseErrorsNameLineAndField) {
  const auto dir = testing::temp_dir("handeye_errors");
  write(dir / "bad.csv", "t,tx,ty,tz,qx,qy,qz,qw\n0,1,0,0,0,0,0,1\n1,1,0,zz,0,0,0,1\n");
  try {
    read_pose_csv(dir / "bad.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 3);
    EXPECT_EQ(e.context().field, "tz");
    EXPECT_NE(e.context().file.find("bad.csv"), std::string::npos);
  }
  write(dir / "short.csv", "0,1,0,0,0,0,0,1\n1,1,0,0,0,0\n");
  try {
    read_pose_csv(dir / "short.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 2);
  }
  write(dir / "quat.csv", "0,1,0,0,0,0,0,2\n");
  try {
    read_pose_csv(dir / "quat.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "q");
  }
  EXPECT_THROW(read_pairs_file(dir / "missing.csv"), Error);
}

TEST(HandeyeIo, CalibrationFileRoundTrip) {
  const auto dir = testing::temp_dir("handeye_calibration");
  CalibrationFile c;
  c.device_from_marker =
      SE3(SO3::exp(Eigen::Vector3d(0.1, 2.0, -0.3)), Eigen::Vector3d(0.01, 0.02, 0.03));
  c.vr_from_camera = SE3(SO3::exp(Eigen::Vector3d(-1, 0.5, 0.2)), Eigen::Vector3d(1, 2, 3));
  c.sigma = 1.25;
  write_calibration(dir / "c.yaml", c);
  const CalibrationFile back = read_calibration(dir / "c.yaml");
  EXPECT_LT(rotation_distance(back.device_from_marker, c.device_from_marker), 1e-9);
  EXPECT_LT(translation_distance(back.vr_from_camera, c.vr_from_camera), 1e-9);
  EXPECT_DOUBLE_EQ(back.sigma, 1.25);
  write(dir / "bad.yaml", "device_from_marker: [1, 0, 0]\n");
  try {
    read_calibration(dir / "bad.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 1);
    EXPECT_EQ(e.context().field, "device_from_marker");
  }
}

// A calibration whose rotation is scaled or sheared, whose last row is not 0 0 0 1, or with a
// NaN is refused with the file, key and line named: it would re-anchor a participant wrongly
// (the session check, the node and its hot reload all read calibrations here).
TEST(HandeyeIo, NonRigidCalibrationsAreRefusedNamingTheKey) {
  const auto dir = testing::temp_dir("handeye_non_rigid");
  const std::string marker = "device_from_marker: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"scaled", "vr_from_camera: [1.1,0,0,1, 0,1.1,0,2, 0,0,1.1,3, 0,0,0,1]"},
      {"sheared", "vr_from_camera: [1,0.2,0,1, 0,1,0,2, 0,0,1,3, 0,0,0,1]"},
      {"last row", "vr_from_camera: [1,0,0,1, 0,1,0,2, 0,0,1,3, 0,0.5,0,1]"},
      {"mirrored", "vr_from_camera: [-1,0,0,1, 0,1,0,2, 0,0,1,3, 0,0,0,1]"},
      {"nan", "vr_from_camera: [1,0,0,nan, 0,1,0,2, 0,0,1,3, 0,0,0,1]"},
  };
  for (const auto& [name, line] : cases) {
    write(dir / "c.yaml", marker + line + "\n");
    try {
      read_calibration(dir / "c.yaml");
      ADD_FAILURE() << name << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.context().field, "vr_from_camera") << name;
      EXPECT_EQ(e.context().line, 2) << name;
      EXPECT_EQ(e.context().file, (dir / "c.yaml").string()) << name;
    }
  }
}

TEST(HandeyeGuidance, SessionAndNextRegistration) {
  SimulationOptions o;
  o.seed = 12;
  o.num_registrations = 12;
  const Simulation sim = simulate(o);
  const std::span<const Registration> all(sim.registrations);

  const SessionStatus two = session_status(all.first(2));
  EXPECT_FALSE(two.solvable);
  EXPECT_NE(two.advice.find("1 more"), std::string::npos) << two.advice;
  const SessionStatus five = session_status(all.first(5));
  EXPECT_TRUE(five.solvable) << five.advice;
  EXPECT_NEAR(five.weakest_axis.norm(), 1.0, 1e-9);
  EXPECT_GT(five.information_logdet, session_status(all.first(3)).information_logdet);

  // A new, different pose adds information; repeating an existing one does not.
  const NextRegistrationAdvice fresh = assess_next_registration(all.first(5), all[5]);
  EXPECT_TRUE(fresh.adds_information) << fresh.advice;
  EXPECT_GT(fresh.information_gain, 0.05);
  const NextRegistrationAdvice repeat = assess_next_registration(all.first(5), all[2]);
  EXPECT_FALSE(repeat.adds_information);
  EXPECT_NE(repeat.advice.find("too close"), std::string::npos) << repeat.advice;
  // A marker pose from another instant fails the angle test.
  Registration wrong = all[6];
  wrong.camera_from_marker = all[7].camera_from_marker;
  const NextRegistrationAdvice bad = assess_next_registration(all.first(5), wrong);
  EXPECT_FALSE(bad.consistent);
  EXPECT_FALSE(bad.adds_information);
}

}  // namespace
}  // namespace coloc::registration::handeye
