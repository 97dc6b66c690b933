#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/settings/settings.hpp"
#include "tests/testing/data.hpp"

namespace coloc::settings {
namespace {

void expect_tum1(const Settings& s) {
  ASSERT_TRUE(std::holds_alternative<PinholeCamera>(s.camera));
  const auto& cam = std::get<PinholeCamera>(s.camera);
  EXPECT_DOUBLE_EQ(cam.fx, 517.306408);
  EXPECT_DOUBLE_EQ(cam.fy, 516.469215);
  EXPECT_DOUBLE_EQ(cam.cx, 318.643040);
  EXPECT_DOUBLE_EQ(cam.cy, 255.313989);
  EXPECT_DOUBLE_EQ(cam.distortion[0], 0.262383);
  EXPECT_DOUBLE_EQ(cam.distortion[4], 1.163314);
  EXPECT_EQ(cam.width, 640);
  EXPECT_EQ(cam.height, 480);
  EXPECT_DOUBLE_EQ(s.fps, 30.0);
  EXPECT_TRUE(s.rgb_order);
  ASSERT_TRUE(s.depth.has_value());
  EXPECT_DOUBLE_EQ(s.depth->depth_map_factor, 5000.0);
  EXPECT_DOUBLE_EQ(s.depth->th_depth, 40.0);
  EXPECT_EQ(s.orb.n_features, 1000);
  EXPECT_DOUBLE_EQ(s.orb.scale_factor, 1.2);
  EXPECT_EQ(s.orb.n_levels, 8);
  EXPECT_EQ(s.orb.ini_th_fast, 20);
  EXPECT_EQ(s.orb.min_th_fast, 7);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();  // Viewer.* is ignored silently
}

TEST(Settings, LoadsOrbSlam2FileUnchanged) {
  COLOC_REQUIRE_DATA(file, "orbslam_configs/ORB_SLAM2_RGB-D_TUM1.yaml");
  const Settings s = load_settings(file);
  EXPECT_EQ(s.file_version, 0);
  expect_tum1(s);
  // Camera.bf = 40 (pixels * metres): baseline = bf / fx; close depth = ThDepth * baseline.
  EXPECT_DOUBLE_EQ(s.depth->bf, 40.0);
  EXPECT_NEAR(s.depth->baseline, 40.0 / 517.306408, 1e-12);
  EXPECT_NEAR(s.depth->close_depth, 40.0 * 40.0 / 517.306408, 1e-12);
}

TEST(Settings, LoadsOrbSlam3V1FileUnchanged) {
  COLOC_REQUIRE_DATA(file, "orbslam_configs/ORB_SLAM3_v1.0_RGB-D_TUM1.yaml");
  const Settings s = load_settings(file);
  EXPECT_EQ(s.file_version, 1);
  expect_tum1(s);
  EXPECT_DOUBLE_EQ(s.depth->baseline, 0.07732);
  EXPECT_NEAR(s.depth->bf, 0.07732 * 517.306408, 1e-9);
  EXPECT_NEAR(s.depth->close_depth, 40.0 * 0.07732, 1e-12);
}

std::filesystem::path write(const std::string& name, const std::string& body) {
  const auto dir = testing::temp_dir("settings");
  const auto path = dir / name;
  std::ofstream(path) << "%YAML:1.0\n" << body;
  return path;
}

const char* kMinimal =
    "Camera.type: \"PinHole\"\nCamera.fx: 500.0\nCamera.fy: 500.0\nCamera.cx: 320.0\n"
    "Camera.cy: 240.0\n";

TEST(Settings, FisheyeOwnSectionsAndUnknownKeys) {
  const auto path = write("kb.yaml",
                          "File.version: \"1.0\"\nCamera.type: \"KannalaBrandt8\"\n"
                          "Camera1.fx: 190.9\nCamera1.fy: 190.9\nCamera1.cx: 254.9\n"
                          "Camera1.cy: 256.8\nCamera1.k1: 0.003\nCamera1.k2: 0.0007\n"
                          "Camera1.k3: -0.002\nCamera1.k4: 0.0002\nMarkers.dictionary: "
                          "\"DICT_APRILTAG_36h11\"\nMarkers.size: 0.2\nFusion.processNoise: "
                          "0.002\nOSC.port: 9000\nCamera.fsp: 30\nIMU.NoiseAccel: 2.0e-3\n"
                          "Coloc.tracking.min_local_inliers: 25\nColoc.mapping.local_ba: 0\n"
                          "Stereo.T_c1_c2: !!opencv-matrix\n  rows: 2\n  cols: 2\n  dt: f\n"
                          "  data: [1.0, 0.5, -2.0, 0.25]\n");
  const Settings s = load_settings(path);
  ASSERT_TRUE(std::holds_alternative<KannalaBrandtCamera>(s.camera));
  EXPECT_DOUBLE_EQ(std::get<KannalaBrandtCamera>(s.camera).distortion[3], 0.0002);
  EXPECT_FALSE(s.depth.has_value());
  EXPECT_EQ(s.markers.dictionary, "DICT_APRILTAG_36h11");
  EXPECT_DOUBLE_EQ(s.markers.size, 0.2);
  // coloc's tuning keys are read as numbers by option name (slam/system/tuning checks the names).
  EXPECT_EQ(s.coloc_options, (std::map<std::string, double>{{"tracking.min_local_inliers", 25.0},
                                                            {"mapping.local_ba", 0.0}}));
  // Keys nothing reads are named, in file order: the misspelt one, and blocks no verb uses.
  EXPECT_EQ(s.warnings, (std::vector<std::string>{"Fusion.processNoise", "OSC.port", "Camera.fsp",
                                                  "IMU.NoiseAccel", "Stereo.T_c1_c2"}));
}

// ORB-SLAM3 v1.0's atlas keys name the map database to continue and to save; a bare name gets
// ".db" as ORB-SLAM3 gives it ".osa".
TEST(Settings, AtlasKeysNameTheMapDatabase) {
  const auto path = write("atlas.yaml", std::string(kMinimal) +
                                            "System.LoadAtlasFromFile: \"site\"\n"
                                            "System.SaveAtlasToFile: \"maps/site_v2.db\"\n");
  const Settings s = load_settings(path);
  EXPECT_EQ(s.load_map, std::filesystem::path("site.db"));
  EXPECT_EQ(s.save_map, std::filesystem::path("maps/site_v2.db"));
  EXPECT_TRUE(s.warnings.empty());
  const Settings none = load_settings(write("no_atlas.yaml", kMinimal));
  EXPECT_TRUE(none.load_map.empty() && none.save_map.empty());
}

// Broken files: the error names the key and the file.
void expect_error(const std::filesystem::path& path, const std::string& key) {
  try {
    load_settings(path);
    FAIL() << "expected an error for " << key;
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, key) << e.what();
    EXPECT_EQ(e.context().file, path.string());
    EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos);
  }
}

TEST(Settings, BrokenFilesNameKeyAndFile) {
  expect_error(write("missing_fx.yaml", "Camera.fy: 500.0\nCamera.cx: 320.0\nCamera.cy: 240.0\n"),
               "Camera.fx");
  expect_error(write("string_fx.yaml", std::string(kMinimal) + "Camera.k1: \"abc\"\n"),
               "Camera.k1");
  expect_error(write("bad_type.yaml",
                     "Camera.type: \"Fisheye9\"\nCamera.fx: 1\nCamera.fy: 1\nCamera.cx: 1\n"
                     "Camera.cy: 1\n"),
               "Camera.type");
  expect_error(write("bad_levels.yaml", std::string(kMinimal) + "ORBextractor.nLevels: 2.5\n"),
               "ORBextractor.nLevels");
  expect_error(write("no_bf.yaml", std::string(kMinimal) + "ThDepth: 40.0\n"), "Camera.bf");
  expect_error(write("version.yaml", std::string("File.version: \"2.0\"\n") + kMinimal),
               "File.version");
  expect_error(write("readout.yaml", std::string(kMinimal) + "Camera.readoutTime: -0.02\n"),
               "Camera.readoutTime");
}

// coloc's rolling-shutter key: absent = unknown (estimated online); the shipped TUM file gives
// the Kinect's.
TEST(Settings, ReadoutTime) {
  EXPECT_FALSE(load_settings(write("minimal.yaml", kMinimal)).readout_time.has_value());
  const Settings s =
      load_settings(write("readout_ok.yaml", std::string(kMinimal) + "Camera.readoutTime: 0.02\n"));
  EXPECT_DOUBLE_EQ(*s.readout_time, 0.02);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(Settings, ImuPlacement) {
  EXPECT_FALSE(load_settings(write("no_imu.yaml", kMinimal)).imu_from_cam);
  const std::string matrix =
      "IMU.T_b_c1: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: f\n"
      "   data: [0., -1., 0., 0.02, 1., 0., 0., 0.005, 0., 0., 1., 0.01, 0., 0., 0., 1.]\n";
  const Settings s = load_settings(write("imu.yaml", std::string(kMinimal) + matrix));
  ASSERT_TRUE(s.imu_from_cam);
  EXPECT_NEAR(s.imu_from_cam->matrix()(0, 1), -1.0, 1e-7);
  EXPECT_NEAR(s.imu_from_cam->matrix()(1, 3), 0.005, 1e-7);
  EXPECT_TRUE(s.warnings.empty());
  // Not a 4x4, not a rotation, not a matrix: named errors.
  expect_error(write("imu_3x3.yaml", std::string(kMinimal) +
                                         "IMU.T_b_c1: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
                                         "   dt: d\n   data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"),
               "IMU.T_b_c1");
  std::string scaled = matrix;
  scaled.replace(scaled.find("[0., -1."), 8, "[0., -2.");
  expect_error(write("imu_scaled.yaml", std::string(kMinimal) + scaled), "IMU.T_b_c1");
  expect_error(write("imu_number.yaml", std::string(kMinimal) + "IMU.T_b_c1: 3\n"), "IMU.T_b_c1");
  // A shape no 4x4 has is refused before OpenCV allocates it (rows 2^32: 64 GiB, found by
  // scripts/fuzz_yaml in a camera calibration's color_from_depth).
  expect_error(write("imu_huge.yaml", std::string(kMinimal) +
                                          "IMU.T_b_c1: !!opencv-matrix\n   rows: 4294967296\n"
                                          "   cols: 4\n   dt: d\n   data: [1, 0]\n"),
               "IMU.T_b_c1");
}

TEST(Settings, GyroNoiseFigures) {
  const Settings none = load_settings(write("no_gyro.yaml", kMinimal));
  EXPECT_FALSE(none.gyro_noise_density);
  EXPECT_FALSE(none.gyro_random_walk);
  const Settings s = load_settings(
      write("gyro.yaml", std::string(kMinimal) + "IMU.NoiseGyro: 2.4e-4\nIMU.GyroWalk: 2.0e-5\n"));
  EXPECT_DOUBLE_EQ(*s.gyro_noise_density, 2.4e-4);
  EXPECT_DOUBLE_EQ(*s.gyro_random_walk, 2.0e-5);
  EXPECT_TRUE(s.warnings.empty());
  expect_error(write("gyro_neg.yaml", std::string(kMinimal) + "IMU.NoiseGyro: -1e-4\n"),
               "IMU.NoiseGyro");
  expect_error(write("gyro_text.yaml", std::string(kMinimal) + "IMU.GyroWalk: \"fast\"\n"),
               "IMU.GyroWalk");
}

// ORB-SLAM3's other IMU keys (in its IMU-RGBD files and in the twin's camera.yaml) are known:
// checked, and no "unknown key" warning, although coloc does not use them.
TEST(Settings, OrbSlam3ImuKeysAreKnownAndChecked) {
  const Settings s = load_settings(
      write("imu_keys.yaml", std::string(kMinimal) +
                                 "IMU.NoiseAcc: 2.0e-3\nIMU.AccWalk: 3.0e-3\nIMU.Frequency: 200.0\n"
                                 "IMU.InsertKFsWhenLost: 0\n"));
  EXPECT_TRUE(s.warnings.empty());
  expect_error(write("acc_neg.yaml", std::string(kMinimal) + "IMU.NoiseAcc: -1\n"), "IMU.NoiseAcc");
  expect_error(write("rate_zero.yaml", std::string(kMinimal) + "IMU.Frequency: 0\n"),
               "IMU.Frequency");
  expect_error(write("insert.yaml", std::string(kMinimal) + "IMU.InsertKFsWhenLost: 2\n"),
               "IMU.InsertKFsWhenLost");
}

TEST(Settings, UnreadableFilesAreErrors) {
  EXPECT_THROW(load_settings("/nonexistent/settings.yaml"), Error);
  const auto dir = testing::temp_dir("settings_garbage");
  std::ofstream(dir / "garbage.yaml") << "%YAML:1.0\nCamera.fx: [1, 2\n  : : :\n";
  EXPECT_THROW(load_settings(dir / "garbage.yaml"), Error);
}

// Issue 17: values a camera cannot have are errors naming the key, not a run that fails later
// (a zero depth scale, std::bad_alloc from a billion features, NaN from ".nan").
TEST(Settings, PhysicallyImpossibleValuesNameTheKey) {
  const std::string depth = std::string(kMinimal) + "Camera.bf: 40.0\nThDepth: 40.0\n";
  expect_error(write("zero_scale.yaml", depth + "DepthMapFactor: 0.0\n"), "DepthMapFactor");
  expect_error(write("nan_scale.yaml", depth + "DepthMapFactor: .nan\n"), "DepthMapFactor");
  expect_error(
      write("huge_features.yaml", std::string(kMinimal) + "ORBextractor.nFeatures: 1000000000\n"),
      "ORBextractor.nFeatures");
  expect_error(write("overflow.yaml", std::string(kMinimal) + "ORBextractor.nLevels: 1e30\n"),
               "ORBextractor.nLevels");
  expect_error(write("inf_fx.yaml", "Camera.fx: .inf\nCamera.fy: 1\nCamera.cx: 1\nCamera.cy: 1\n"),
               "Camera.fx");
  expect_error(write("neg_width.yaml", std::string(kMinimal) + "Camera.width: -640\n"),
               "Camera.width");
  expect_error(write("fast.yaml", std::string(kMinimal) + "ORBextractor.iniThFAST: 0\n"),
               "ORBextractor.iniThFAST");
  expect_error(write("fps.yaml", std::string(kMinimal) + "Camera.fps: 0\n"), "Camera.fps");
}

TEST(Settings, PathsThatAreNotRegularFilesAreRefusedBeforeOpening) {
  const auto dir = testing::temp_dir("settings_paths");
  const std::filesystem::path fifo = dir / "pipe.yaml";
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // Opening a FIFO for reading would block forever; the check names what the path is.
  try {
    load_settings(fifo);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();
    EXPECT_EQ(e.context().file, fifo.string());
  }
  try {
    load_settings(dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("directory"), std::string::npos) << e.what();
  }
  std::filesystem::remove(fifo);
}

// The fuzzer's first finding was a file with a NUL byte on which OpenCV asserted while the keys
// were listed; binary input is now refused with its offset before OpenCV sees it.
TEST(Settings, BinaryAndParserTrapsAreErrorsWithAPlace) {
  const auto dir = testing::temp_dir("settings_traps");
  std::ofstream(dir / "nul.yaml", std::ios::binary) << std::string("%YAML:1.0\nCamera.fx: 1\0", 24);
  try {
    load_settings(dir / "nul.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().offset, 22u) << e.what();
  }
  // OpenCV 4.6's reader loops forever on this (found by scripts/fuzz_settings).
  std::ofstream(dir / "dashes.yaml") << "%YAML:1.0\n----x\n----\nr";
  try {
    load_settings(dir / "dashes.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 2) << e.what();
  }
}

}  // namespace
}  // namespace coloc::settings
