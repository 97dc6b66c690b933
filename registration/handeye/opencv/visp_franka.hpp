#pragma once
// Loader for the ViSP Franka hand-eye recordings ($COLOC_DATA/handeye_visp_franka): eye-to-hand
// = a fixed camera viewing an AprilTag 36h11 on the robot's end-effector, the same geometry as a
// marker on a VR controller. Mapping onto handeye.hpp's frames: "vr" = robot base, "device" =
// end-effector, "marker" = the tag, "camera" = the fixed camera. The robot poses
// franka_pose_rPe_N.yaml hold base_from_end_effector as [t (m); theta-u (rad)].

#include <filesystem>
#include <string>
#include <vector>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

struct FrankaSession {
  std::vector<Registration> registrations;  // images in which the tag was found
  std::vector<std::string> images;          // their file names
  std::vector<double> reprojection_rms_px;  // PnP reprojection RMS per registration
  int num_images = 0;
  double tag_size = 0.0;  // m, from apriltag-data.txt
};

// Reads franka_camera.xml (pinhole px, py, u0, v0; no distortion), apriltag-data.txt (tag size),
// franka_pose_rPe_N.yaml and franka_image-N.png for N = 1, 2, ... while they exist; detects the
// tag (OpenCV aruco DICT_APRILTAG_36h11) and solves PnP (IPPE_SQUARE). Throws coloc::Error
// naming the file on unreadable or malformed input.
FrankaSession load_visp_franka_eye_to_hand(const std::filesystem::path& directory);

}  // namespace coloc::registration::handeye
