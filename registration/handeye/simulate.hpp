#pragma once
// Seeded synthetic registration sessions from a physical model, so that the conventions are
// tested from first principles and the solvers can be compared at known noise.
//
// The model (world frame: z up, metres): a camera on a tripod looks at a workspace; the VR
// system's origin is somewhere else in the room, yawed; a controller is held at random positions
// in the workspace with the marker (fixed at device_from_marker on the controller) facing the
// camera within max_tilt and spun about its normal. What the sensors report:
//   vr_from_device_i     = world_from_vr^-1 * world_from_device_i, then device noise
//   camera_from_marker_i = world_from_camera^-1 * world_from_device_i * device_from_marker,
//                          then marker noise (plus marker_depth_noise along the ray), then the
//                          translation divided by `scale` (a wrong marker size), so sigma = scale
//                          recovers it.
// Noise: pose -> (R * Exp(n_r), t + n_t), n_r and n_t Gaussian per axis (rotation in the body
// frame, translation in the parent frame). Outliers: a gross error applied to either pose.

#include <cstdint>
#include <vector>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

struct SimulationOptions {
  int num_registrations = 10;
  double device_rotation_noise = 0.001;     // rad, per axis
  double device_translation_noise = 0.001;  // m, per axis
  double marker_rotation_noise = 0.002;     // rad, per axis
  double marker_translation_noise = 0.005;  // m, per axis
  // Extra PnP noise along the viewing ray (m): depth is what a small marker measures worst.
  double marker_depth_noise = 0.0;
  double outlier_fraction = 0.0;     // rounded to a count of registrations
  double outlier_rotation = 0.2;     // rad: gross errors are in [1, 3] x this
  double outlier_translation = 0.1;  // m:   and in [1, 3] x this
  double scale = 1.0;                // sigma to recover (true = scale * measured)
  double camera_distance = 1.5;      // m, camera to workspace centre
  double workspace_radius = 0.35;    // m
  double max_tilt = 0.8;             // rad, marker normal vs direction to the camera
  double max_spin = 1.2;             // rad, marker spin about its normal
  double marker_offset = 0.08;       // m, |translation of device_from_marker|
  std::uint64_t seed = 1;

  void check() const;  // throws coloc::Error naming the bad field
};

struct Simulation {
  std::vector<Registration> registrations;
  std::vector<bool> is_outlier;
  SE3 device_from_marker;  // the truth
  SE3 vr_from_camera;      // the truth
  SE3 world_from_camera;
  SE3 world_from_vr;
  std::vector<SE3> world_from_device;  // true controller poses
  double scale = 1.0;
};

Simulation simulate(const SimulationOptions& options);

// The NoiseModel that matches the simulated noise.
NoiseModel noise_model(const SimulationOptions& options);

// Rotation (rad) and translation (m) error of an estimate against the truth.
struct PoseError {
  double rotation = 0.0;
  double translation = 0.0;
};
PoseError pose_error(const SE3& estimate, const SE3& truth);

}  // namespace coloc::registration::handeye
