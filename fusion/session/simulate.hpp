#pragma once
// A seeded simulation of a shared session (`coloc bench session --accuracy`): 2-8 participants
// of different XR systems walk a building (the twin's walk, or the fusion simulation's hall),
// each system with its own tracking-space origin, noise and drift, calibrated to the anchor
// camera by a simulated hand-eye session (handeye::simulate + solve: each calibration has a real
// error and a covariance). Their head and controller poses go through a Session; every published
// pose is compared with the truth in the world frame.
//
// Also measured: the pairwise relative head pose (what two users see of each other) against what
// the two participants' error models predict, and An et al.'s locked-controller stability (Table
// 2): participant 0's controller 0 and participant 1's controller 0 locked together.
//
// The prediction, per participant, as a world-frame error e of its published head
// (Exp(e) * true head * Exp(tracking noise)), sampled 50 times per trial at 1 Hz of the walk:
// - placed by the calibration only: e = Ad(world_from_camera) (-eps), eps ~ the calibration's
//   covariance (vr_from_camera_covariance);
// - drift-corrected: the fuser's filter linearized (its gains from its own P recursion with the
//   session's Q and R) run over the simulated localizer noise and tracking noise mapped to the
//   world (Ad(head)), and over the system's drift, which it lags; the calibration's error is part
//   of the drift the fuser estimates and cancels.
// Both heads then take their systems' tracking noise. The fusers' Mahalanobis gate is not in that
// model (MultiUserOptions::fuser_gating turns it off to compare like with like).

#include <cstdint>
#include <string>
#include <vector>

#include "fusion/session/config.hpp"
#include "registration/handeye/compose.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::fusion::session {

// One kind of XR system: how it tracks (noise, drift) and whether a localizer corrects it.
struct SystemModel {
  std::string name;
  ParticipantKind kind = ParticipantKind::kVr;
  double position_noise = 0.0004;  // m, white, per sample
  double rotation_noise = 0.0002;  // rad, white, per sample
  double drift_speed = 0.0;        // m/s, constant drift of the tracking space (random heading)
  double yaw_drift = 0.0;          // rad/s
  double global_rate = 0.0;        // Hz of its localizer's global poses (0: none)
};
// Lighthouse (VIVE Pro: sub-mm noise, no drift), inside-out (Quest 2: mm noise, drift, a camera
// localizer on the headset), an AR tablet (ARKit-like, drift, localizer).
SystemModel vive_model();
SystemModel quest_model();
SystemModel tablet_model();

struct MultiUserOptions {
  int participants = 4;             // 2..8; systems cycle VIVE, Quest, tablet, VIVE, ...
  double duration = 60.0;           // s
  double rate = 90.0;               // Hz, head and controller samples
  double global_sigma = 0.015;      // m, localizer noise (rotation: global_sigma / 3 rad)
  int registrations = 10;           // per hand-eye calibration (handeye::simulate protocol noise)
  double occluded_fraction = 0.05;  // participant 1's controller 1: this share of samples jump
  double occluded_jump = 0.3;       // m, typical size of such a jump
  bool drift = true;                // false: no system drifts (calibration + noise only)
  // The fusers' Mahalanobis gate (DriftFilterOptions::gating). Off, the fusers are the linear
  // filters the prediction models; on (the session's default) is what users get.
  bool fuser_gating = true;
  int trials = 10;  // independent sessions (new calibrations, seeds)
  std::uint32_t seed = 1;
  Trajectory walk;  // world_from_head of a walk (the twin's); empty: fusion's simulated hall

  void check() const;  // throws coloc::Error naming the field
};

struct UserError {
  std::string id;
  std::string system;
  double head_position_rms = 0.0;  // m, every published head pose vs truth
  double head_rotation_rms = 0.0;  // rad
  double head_position_p95 = 0.0;
  double controller_position_rms = 0.0;  // m, controllers (occluded one included)
  double controller_position_p95 = 0.0;
  double calibration_error = 0.0;  // m, vr_from_camera translation error of its calibration
  std::size_t published = 0;
};

struct PairError {
  std::string a, b;
  double measured_position_rms = 0.0;   // m: relative head pose (a^-1 b) vs truth
  double predicted_position_rms = 0.0;  // m: from both participants' error models (above)
  double measured_rotation_rms = 0.0;   // rad
  double predicted_rotation_rms = 0.0;  // rad
  bool calibration_limited = false;     // neither system drifts: the prediction is complete
};

struct StabilityRow {
  double rotation_mean = 0.0;  // rad, |mean relative rotation| (mu)
  double rotation_mean_abs = 0.0, rotation_rms = 0.0;
  double translation_mean = 0.0;  // m, |mean relative translation| (mu)
  double translation_mean_abs = 0.0, translation_rms = 0.0;
  std::size_t poses = 0;
};

// An et al.'s Table 2 row for two locked controllers: their poses vr_a_from_controller_a and
// vr_b_from_controller_b at matched times, through the two systems' calibrations
// (registration::handeye::locked_controller_stability). Empty poses give an empty row.
StabilityRow stability_row(const std::vector<SE3>& a, const std::vector<SE3>& b,
                           const SE3& vr_a_from_camera, const SE3& vr_b_from_camera);

struct MultiUserReport {
  std::vector<UserError> users;  // per participant, over all trials
  std::vector<PairError> pairs;  // per pair, over all trials
  StabilityRow stability;        // locked controllers, first trial
  std::size_t published = 0;
  std::size_t stale_events = 0;
};

MultiUserReport simulate_multi_user(const MultiUserOptions& options);

// The covariance of a solved vr_from_camera, right perturbation in the camera frame
// (vr_from_camera_true = estimate * Exp(eps), eps = (rho, phi)): the error X's covariance carries
// over (Jacobian averaged over the registrations) plus the spread of the per-registration
// estimates divided by their number.
Matrix6d vr_from_camera_covariance(std::span<const registration::handeye::Registration> regs,
                                   const std::vector<bool>& used, const SE3& device_from_marker,
                                   const SE3& vr_from_camera, const Matrix6d& x_covariance);

}  // namespace coloc::fusion::session
