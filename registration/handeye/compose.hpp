#pragma once
// Composition of hand-eye results (An et al. 2023, sections I.B and III.F): the per-registration
// camera-to-VR transforms, their average, the link between two VR systems and the stability of
// two controllers locked together. Frames as in handeye.hpp.

#include <span>
#include <vector>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

// vr_from_camera_i = vr_from_device_i * device_from_marker * (sigma-scaled camera_from_marker_i)^-1
// for every registration (the paper's M_c2v = M_dev^-1 M_m2d M_mk).
std::vector<SE3> vr_from_camera_per_registration(std::span<const Registration> registrations,
                                                 const SE3& device_from_marker, double sigma = 1.0);

// Mean pose: rotation by the chordal L2 mean on SO(3) (the rotation nearest, in Frobenius norm,
// to the mean rotation matrix), translation by the arithmetic mean. Empty input gives identity.
SE3 chordal_mean(std::span<const SE3> poses);

// The paper's T_A2B = M_c2v^B (M_c2v^A)^-1 = vr_b_from_camera * camera_from_vr_a.
SE3 vr_b_from_vr_a(const SE3& vr_a_from_camera, const SE3& vr_b_from_camera);

// Spread of poses around their chordal mean: deviations are the rotation angle and translation
// norm of mean^-1 * pose_i (rotation in rad, translation in m).
struct Dispersion {
  SE3 mean;
  double rotation_mean_abs = 0.0;  // delta_ave of the rotation angle
  double rotation_rms = 0.0;       // delta_rms
  double rotation_max = 0.0;
  double translation_mean_abs = 0.0;
  double translation_rms = 0.0;
  double translation_max = 0.0;
};
Dispersion dispersion(std::span<const SE3> poses);

// Two controllers locked together, tracked by systems A and B at the same instants:
// device_b_from_device_a_i = vr_b_from_device_b_i^-1 * vr_b_from_camera * vr_a_from_camera^-1 *
// vr_a_from_device_a_i (the paper's M_dev^{A2B}_i) should be constant; returns its dispersion.
// Throws coloc::Error when the spans differ in size or are empty.
Dispersion locked_controller_stability(std::span<const SE3> vr_a_from_device_a,
                                       std::span<const SE3> vr_b_from_device_b,
                                       const SE3& vr_a_from_camera, const SE3& vr_b_from_camera);

}  // namespace coloc::registration::handeye
