#pragma once
// Hand-eye registration of a VR system to a camera (AX = XB), after An et al. 2023,
// "Integrating heterogeneous VR systems into physical space" (docs/design.md lists the papers).
//
// Frames. Every pose b_from_a maps points from frame a to frame b (p_b = b_from_a * p_a, column
// vectors); metres and radians throughout.
//   vr      the VR system's tracking space (its origin is chosen by the VR runtime)
//   device  the controller's body frame as the VR system tracks it
//   marker  the marker fixed casually somewhere on the controller
//   camera  the camera that sees the marker (it anchors the shared physical space)
// One registration i is a simultaneous pair (vr_from_device_i, camera_from_marker_i): what the VR
// system and PnP report. The two constant unknowns are
//   X = device_from_marker           (the paper's M_m2d; rigid marker on a rigid controller)
//   vr_from_camera = vr_from_device_i * X * camera_from_marker_i^-1   (the paper's M_c2v)
// In the paper's notation M_dev = device_from_vr and M_mk = marker_from_camera, so its
// A_ij = M_dev_j M_dev_i^-1 = device_j_from_device_i and B_ij = marker_j_from_marker_i.
//
// A camera fixed on a headset is the same problem (see headset_registration()): the headset is
// the "device", the camera plays the "marker", and a board fixed in the room plays the "camera".
//
// Unknown marker size: PnP translations are then off by one factor; sigma is defined by
//   true camera_from_marker translation = sigma * measured translation.
//
// Thread-safety: all functions are pure (no shared state) and may run concurrently.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "slam/core/se3.hpp"

namespace coloc::registration::handeye {

// One registration: both poses taken at the same instant.
struct Registration {
  SE3 vr_from_device;      // the VR system's pose of the controller
  SE3 camera_from_marker;  // the marker pose as PnP returns it
};

// The camera-on-headset variant: vr_from_headset * headset_from_camera * camera_from_board is
// constant (the board is fixed in the room). Returns the registration whose solution X is
// headset_from_camera and whose "vr_from_camera" is vr_from_board.
Registration headset_registration(const SE3& vr_from_headset, const SE3& camera_from_board);

// Which unknown the linear (paper) stage solves directly; the other follows by composition and
// averaging. The nonlinear refinement estimates both jointly, so after refinement the choice
// only changes the starting point.
enum class Target {
  kDeviceFromMarker,  // X = M_m2d: A_ij = device_j_from_device_i, B_ij = marker_j_from_marker_i
  kVrFromCamera,      // X = M_c2v: A_ij = vr_from_device_j * (vr_from_device_i)^-1,
                      //            B_ij = camera_from_marker_j * (camera_from_marker_i)^-1
};

enum class PairMode {
  kAll,          // every pair i < j (the paper's choice: redundancy dampens outliers)
  kConsecutive,  // (i, i+1) only; a registration failing the angle test is skipped
};

// Expected measurement noise (standard deviation per axis). Used to weight rotation against
// translation in the refinement; the covariance is rescaled by the observed residuals, so only
// the ratios must be right.
struct NoiseModel {
  double device_rotation = 0.002;     // rad, VR tracking
  double device_translation = 0.002;  // m
  double marker_rotation = 0.01;      // rad, PnP on a small marker
  double marker_translation = 0.005;  // m
  // Extra standard deviation along the camera's viewing ray (PnP depth), m; 0 = isotropic.
  double marker_depth = 0.0;
};

// RANSAC over minimal sets of 3 registrations. All triples are enumerated (deterministic) when
// there are at most max_iterations of them; otherwise triples are drawn with `seed`.
struct RansacOptions {
  int max_iterations = 300;
  double inlier_rotation = 0.035;     // rad: |angle(predicted vs measured camera_from_marker)|
  double inlier_translation = 0.025;  // m: |predicted - measured marker position in camera|
  double min_inlier_fraction = 0.5;   // fewer inliers than this => not usable
  std::uint64_t seed = 7;
};

struct Options {
  Target target = Target::kDeviceFromMarker;
  PairMode pairs = PairMode::kAll;
  bool estimate_scale = false;  // unknown marker size: estimate sigma
  // A pair is dropped when the rotation angles of A_ij and B_ij differ by more than this (they
  // are equal for a rigid marker on a rigid controller; paper, Lemma 1).
  double max_angle_mismatch = 0.05;  // rad (~2.9 deg)
  // Pairs rotating less than this carry no usable rotation axis and are not used.
  double min_pair_rotation = 0.05;  // rad
  // Rotation axes must spread at least this much (see Conditioning::axis_spread).
  double min_axis_spread = 0.17;  // rad (~10 deg)
  // In PairMode::kAll a registration is dropped when more than this fraction of its pairs fails
  // the angle test (one bad registration spoils all its pairs).
  double max_bad_pair_fraction = 0.5;
  bool robust = false;  // RANSAC over registrations, then refit on the inliers
  RansacOptions ransac;
  bool refine = true;  // Ceres refinement of X, vr_from_camera (and sigma) jointly
  // Huber loss on noise-normalized residuals in robust mode (plain least squares, i.e. maximum
  // likelihood, otherwise); <= 0 disables it.
  double huber_delta = 3.0;
  int max_refine_iterations = 50;
  NoiseModel noise;
  // Re-estimate the noise model from the residuals and refine again (rounds of variance
  // component estimation), so that a wrong `noise` does not bias the weighting. Needs enough
  // registrations (>= 6) to be meaningful; skipped below that.
  int noise_estimation_rounds = 2;
  bool estimate_covariance = true;  // needs refine

  // Throws coloc::Error naming the first bad field.
  void check() const;
};

// How well the data constrain the solution (paper, Theorem: two rotations about different axes).
struct Conditioning {
  // Angle between rotation axes, 2*atan(sqrt(l2/l1)) with l1 >= l2 the largest eigenvalues of
  // sum(a a^T) over unit axes a of A_ij: for two equally used axes it is their angle (rad).
  double axis_spread = 0.0;
  // Smallest singular value of the stacked translation system [(R_A - I) | -R_X t_B] (unitless
  // for the 3 rotation columns; the scale column is in metres).
  double translation_min_singular_value = 0.0;
  double max_pair_rotation = 0.0;  // rad, largest rotation angle among used pairs
  int pairs_used = 0;
  int pairs_rejected = 0;  // failed the angle-consistency test
  int pairs_small = 0;     // rotated less than min_pair_rotation
};

// Per-registration agreement with the solution: measured camera_from_marker against
// vr_from_camera^-1 * vr_from_device * X (marker pose predicted through the VR system).
struct Residuals {
  std::vector<double> rotation;     // rad, per registration (all of them, inliers or not)
  std::vector<double> translation;  // m
  double rotation_rms = 0.0;        // over the registrations used
  double translation_rms = 0.0;
};

struct Summary {
  SE3 device_from_marker;  // X (paper M_m2d)
  SE3 vr_from_camera;      // paper M_c2v
  double sigma = 1.0;      // marker scale (1 unless estimated)
  bool scale_estimated = false;

  std::vector<bool> used;  // per registration: kept by the angle test / RANSAC
  int num_used = 0;
  Conditioning conditioning;
  Residuals residuals;

  bool refined = false;  // the Ceres stage ran and converged
  NoiseModel noise;      // the noise model used last (estimated if noise_estimation_rounds > 0)
  int refine_iterations = 0;
  // Covariance of X in its tangent space, ordered (d_t, d_theta): X = (Exp(d_theta) R, t + d_t),
  // d_theta in the device frame; metres and radians. Rescaled by the residual variance factor.
  std::optional<Matrix6d> device_from_marker_covariance;
  std::optional<double> sigma_stddev;
  double rotation_stddev = 0.0;     // rad, sqrt(trace of the rotation block), if covariance
  double translation_stddev = 0.0;  // m, sqrt(trace of the translation block), if covariance

  std::string message;  // what went wrong or was noteworthy (empty when all is well)

  // Set by solve(): enough registrations survived (and, robust, enough inliers) and the
  // refinement, when asked for, converged.
  bool usable = false;
  bool is_solution_usable() const { return usable; }
};

// Solves for X and vr_from_camera. Throws coloc::Error on bad options or degenerate input
// (fewer than 3 registrations, rotations about one axis only, tiny rotations), with advice on
// what to do in the message; field "registrations".
Summary solve(std::span<const Registration> registrations, const Options& options = {});

}  // namespace coloc::registration::handeye
