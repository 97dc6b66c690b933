#pragma once
// `coloc twin generate`: the seeded digital twin written to a directory.
//
//   OUT/sequence/   TUM RGB-D layout: rgb/ depth/ (16-bit PNG, millimetres), rgb.txt,
//                   depth.txt, associations.txt, groundtruth.txt (world_from_cam), camera.yaml
//                   (ORB-SLAM3 settings incl. IMU), imu.txt, imu_groundtruth.txt
//   OUT/headset/    headset.txt (xr_from_headset, 90 Hz, drifting), headset_groundtruth.txt
//                   (world_from_headset), xr_drift.txt (world_from_xr), calibration.yaml
//                   (cam_from_headset)
//   OUT/scan/       scan.e57 (one data3D per station + 6 pinhole cube faces each), scan.ply
//                   (world frame), stations.txt (world_from_station), faces.txt
//   OUT/groundtruth/ markers.txt (corners, world = scan frame), marker_poses.txt,
//                   scan_from_sequence_start.txt (world_from_cam at the first frame)
//   OUT/twin.yaml   what was generated (preset, seed, counts, camera)
//
// World frame = scan frame: x east, y north, z up, metres. Poses in TUM files are
// "t tx ty tz qx qy qz qw". Deterministic in (options, seed): same seed, same bytes.

#include <cstdint>
#include <filesystem>

#include "registration/twin/floor_plan.hpp"
#include "registration/twin/motion.hpp"
#include "registration/twin/scan.hpp"
#include "registration/twin/sensor_noise.hpp"
#include "slam/core/camera.hpp"

namespace coloc::registration::twin {

struct GenerateOptions {
  Preset preset = Preset::kRoom;
  std::uint64_t seed = 1;
  // RGB-D camera (D455-like colour at 640x480 with a mild lens distortion).
  PinholeCamera camera = default_camera(640, 480);
  double fps = 30.0;
  double max_duration = 0.0;  // seconds of sequence; 0 = the whole walk
  int supersample = 1;        // odd; colour anti-aliasing (costs supersample^2)
  double image_noise = 2.0;   // 8-bit units, Gaussian
  bool motion_blur = false;   // average 3 renders over the exposure
  double exposure = 0.012;    // seconds
  int texture_size = 1024;
  int dictionary = 0;  // OpenCV predefined dictionary (0 = DICT_4X4_50)
  double marker_size = 0.1675;
  WalkOptions walk;  // speed and look-around (preset defaults applied when speed <= 0)
  // Another walk through the same building (scene, markers, scan unchanged): 0 = the preset's
  // walk; 1 and 2 walk the path 0.25 m to its left / right with other head motion (the walk's
  // phases from another seed). To localize a second walk in a map of the first.
  int walk_variant = 0;
  // Pieces of furniture moved between the scan and the sequence (scene.hpp): the scan shows
  // them where they were, the sequence where they are now.
  int moved_furniture = 0;
  ImuOptions imu;
  HeadsetOptions headset;
  DepthNoiseOptions depth;
  bool write_scan = true;
  ScanOptions scan;
  bool quiet = false;  // no progress bars

  static PinholeCamera default_camera(int width, int height);
  void check() const;  // throws coloc::Error naming the bad field
};

// Defaults per preset: room = small and slow (tests, demo), building = >= 40 m loop, site = the
// paper's scale (a 10-minute walk, a 200-million-point scan, DICT_4X4_100 markers).
GenerateOptions preset_options(Preset preset);

struct GenerateSummary {
  std::size_t frames = 0;
  std::size_t imu_samples = 0;
  std::size_t headset_poses = 0;
  std::size_t stations = 0;
  std::size_t scan_points = 0;
  std::size_t markers = 0;
  std::size_t triangles = 0;
  std::size_t moved_furniture = 0;  // pieces actually moved
  double path_length = 0.0;         // metres walked by the camera
  double seconds_scene = 0.0;
  double seconds_sequence = 0.0;
  double seconds_scan = 0.0;
  double seconds_total = 0.0;
  double render_ms_per_frame = 0.0;  // median, colour + depth at the camera's size
};

GenerateSummary generate_twin(const GenerateOptions& options, const std::filesystem::path& out);

}  // namespace coloc::registration::twin
