#pragma once
// Text formats of `coloc handeye` (documented in README.md, section hand-eye).
//
// Pose CSV, one pose per line:      t,tx,ty,tz,qx,qy,qz,qw
//   t in seconds, translation in metres, Hamilton unit quaternion (x, y, z, w), separated by
//   commas and/or whitespace (so TUM trajectory files read too). '#' starts a comment; a first
//   line whose first field is not a number is a header. The device CSV holds vr_from_device (the
//   VR system's pose of the controller), the marker CSV camera_from_marker (PnP's output).
// Pairs file, one registration per line (15 fields):
//   t, vr_from_device tx ty tz qx qy qz qw, camera_from_marker tx ty tz qx qy qz qw
// Parse errors throw coloc::Error naming the file, the 1-based line and the field.

#include <filesystem>
#include <vector>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

struct TimedPose {
  double t = 0.0;  // seconds
  SE3 pose;
};

std::vector<TimedPose> read_pose_csv(const std::filesystem::path& path);
void write_pose_csv(const std::filesystem::path& path, const std::vector<TimedPose>& poses);

struct TimedRegistration {
  double t = 0.0;
  Registration registration;
};

std::vector<TimedRegistration> read_pairs_file(const std::filesystem::path& path);
void write_pairs_file(const std::filesystem::path& path,
                      const std::vector<TimedRegistration>& registrations);

// Pairs each device pose with the marker pose nearest in time within max_dt seconds (each used
// once, nearest first), in device-time order.
std::vector<TimedRegistration> match_by_time(const std::vector<TimedPose>& vr_from_device,
                                             const std::vector<TimedPose>& camera_from_marker,
                                             double max_dt);

// A solved calibration as `coloc handeye solve --output` writes it and `link` / `stability` read
// it: a small YAML file with 4x4 row-major matrices,
//   device_from_marker: [16 numbers]
//   vr_from_camera: [16 numbers]
//   sigma: 1.0
struct CalibrationFile {
  SE3 device_from_marker;
  SE3 vr_from_camera;
  double sigma = 1.0;
};
void write_calibration(const std::filesystem::path& path, const CalibrationFile& calibration);
CalibrationFile read_calibration(const std::filesystem::path& path);

}  // namespace coloc::registration::handeye
