#pragma once
// Settings files as ORB-SLAM users have them, loaded unchanged:
//  - ORB-SLAM2 (and ORB-SLAM3 before v1.0): Camera.fx ... Camera.k3, Camera.bf (baseline times
//    fx, in pixels*metres), ThDepth, DepthMapFactor;
//  - ORB-SLAM3 v1.0 (File.version: "1.0"): Camera1.fx ..., Stereo.b (baseline in metres),
//    Stereo.ThDepth, RGBD.DepthMapFactor;
//  - both: Camera.type ("PinHole" | "KannalaBrandt8"), Camera.width/height, Camera.fps,
//    Camera.RGB, ORBextractor.*; Viewer.* is ignored.
// coloc's own additions live in the same file under their own prefixes: Camera.readoutTime,
// Markers.*, and Coloc.<option> for the SLAM options users tune (slam/tuning/tuning.hpp names
// them; an unknown one is an error there). ORB-SLAM3's System.LoadAtlasFromFile and
// System.SaveAtlasToFile name the map database (slam/mapdb) to continue and to save, and
// IMU.T_b_c1, IMU.NoiseGyro and IMU.GyroWalk place and describe an IMU. Any other key
// (ORB-SLAM3's accelerometer noise figures, ...) is reported as a warning naming it: nothing
// reads it. A missing
// required key or a value of the wrong type is a coloc::Error naming the key and the file.

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::settings {

// Depth sensing (RGB-D or stereo). ORB-SLAM treats RGB-D as a virtual stereo rig whose
// baseline turns depth into a "right" pixel coordinate: u_right = u - bf / depth.
struct DepthSettings {
  double baseline = 0.0;          // metres (Stereo.b, or Camera.bf / fx)
  double bf = 0.0;                // baseline * fx (pixels * metres)
  double close_depth = 0.0;       // metres: points nearer than this are "close" (ThDepth * b)
  double th_depth = 0.0;          // ThDepth as written (baselines)
  double depth_map_factor = 1.0;  // raw depth units per metre (TUM: 5000)
};

struct OrbSettings {
  int n_features = 1000;
  double scale_factor = 1.2;
  int n_levels = 8;
  int ini_th_fast = 20;
  int min_th_fast = 7;
};

struct MarkerSettings {
  std::string dictionary = "DICT_4X4_50";  // OpenCV aruco dictionary name
  double size = 0.1675;                    // marker edge length, metres
};

struct Settings {
  std::filesystem::path source;
  int file_version = 0;  // 0: ORB-SLAM2 style keys, 1: ORB-SLAM3 v1.0 keys
  Camera camera;         // width/height are 0 when the file does not give them
  double fps = 30.0;
  // Camera.readoutTime (coloc's key): seconds from the first to the last row of a rolling-shutter
  // colour camera; 0 = global shutter. Tracking compensates it with the motion model's rotation.
  // Absent (users' ORB-SLAM files): unknown, estimated online by local mapping.
  std::optional<double> readout_time;
  // IMU.T_b_c1 (ORB-SLAM3's key): the camera's pose in the IMU ("body") frame, a 4x4
  // !!opencv-matrix. With it, a sequence's IMU log ties the map's tilt to gravity and the
  // keyframes' relative rotations to the gyro in the global BA (slam/mapping/gravity.hpp,
  // slam/mapping/gyro.hpp).
  std::optional<SE3> imu_from_cam;
  // IMU.NoiseGyro (rad/s/sqrt(Hz)) and IMU.GyroWalk (rad/s^2/sqrt(Hz)), ORB-SLAM3's keys: the
  // gyro's noise density and bias random walk. Absent: optim::BundleProblem::GyroModel's
  // defaults. The accelerometer's figures are not read (gravity has its own model).
  std::optional<double> gyro_noise_density;
  std::optional<double> gyro_random_walk;
  // Camera.RGB: the channel order of the colour images the camera hands to tracking (1 RGB,
  // 0 BGR). Images decoded from files by OpenCV are BGR whatever this says.
  bool rgb_order = false;
  std::optional<DepthSettings> depth;
  OrbSettings orb;
  MarkerSettings markers;
  // System.LoadAtlasFromFile / System.SaveAtlasToFile (ORB-SLAM3 v1.0): the map database to
  // continue and to save to (".db" added to a name without extension); empty when absent.
  std::filesystem::path load_map, save_map;
  // Coloc.<option>: value, by option name (without the prefix); numbers, booleans as 0 / 1.
  std::map<std::string, double> coloc_options;
  // Unknown keys, in file order (also logged as warnings).
  std::vector<std::string> warnings;
};

// Throws coloc::Error (file and key named) for unreadable files, missing required keys and
// wrong value types.
Settings load_settings(const std::filesystem::path& path);
// The same for settings held in memory (a map file keeps the YAML it was built with); `source`
// names them in errors.
Settings parse_settings(const std::string& text, const std::string& source);

}  // namespace coloc::settings
