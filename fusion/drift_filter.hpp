#pragma once
// The paper's drift filter (Michiels et al. 2024, section 5.2) as small pure functions over a
// state, OpenVINS style: no hidden members, every step testable on its own.
//
// The drift D = world_from_xr = world_from_head (global pose) * inverse(xr_from_head) maps the
// headset's own tracking frame "xr" into the scan's frame "world". D is split into a translation
// (metres) and a unit quaternion (x, y, z, w), and each part is filtered by a Kalman filter whose
// transition and measurement matrices are identity. With identity models and isotropic noise the
// covariance stays a multiple of identity, so one variance per part is the whole covariance.
//
// Units of Q and R: the paper's Q = 0.001 and R = 0.9 only set the gain (steady state
// K ~ sqrt(Q/R) ~ 0.033). For the Mahalanobis gate we give them a physical scale: the
// filter with (Q, R, P) and the one with s*(Q, R, P) have the same gain, so choosing
// s = sigma^2 / R (sigma = the physical noise of one global pose) makes P*s a covariance in m^2
// (translation) or quaternion units^2 (rotation; a quaternion component is ~ half the angle).

#include <Eigen/Core>
#include <cstdint>

#include "slam/core/se3.hpp"

namespace coloc::fusion {

struct DriftFilterOptions {
  double process_noise = 1e-3;     // Q per global pose (paper), same scale as R
  double measurement_noise = 0.9;  // R (paper)
  // Physical noise of one global pose, used to scale Q, R, P for gating (see above).
  double translation_sigma = 0.03;  // metres
  double rotation_sigma = 0.01;     // quaternion units (~ half angle in radians; 0.01 ~ 1.1 deg)
  // Mahalanobis gate: reject a global pose whose innovation is improbable. The threshold is on
  // d^2 for each part separately (3 dof: 16.27 is the 99.9 % quantile of chi^2(3)).
  bool gating = true;
  double gate_chi2 = 16.27;
  // After this many consecutive rejections the drift really changed (a headset re-centre or a
  // relocalization); the filter re-initializes on the next global pose instead of rejecting it.
  int reset_after_rejections = 10;

  // Throws coloc::Error naming the bad field.
  void check() const;
};

// The filter state. Value type; the functions below return new states.
struct DriftEstimate {
  bool initialized = false;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // of world_from_xr, metres
  Eigen::Vector4d rotation{0.0, 0.0, 0.0, 1.0};           // quaternion (x, y, z, w), unit norm
  double translation_variance = 0.0;  // P of each translation component, in units of R
  double rotation_variance = 0.0;     // P of each quaternion component, in units of R
  int consecutive_rejections = 0;

  // D = world_from_xr.
  SE3 drift() const;
};

enum class GateDecision : std::uint8_t {
  kInitialized,  // first global pose (or re-initialization after repeated rejections)
  kAccepted,
  kRejected,  // improbable innovation: the estimate did not change (except the counter)
};

struct DriftUpdate {
  DriftEstimate estimate;
  GateDecision decision = GateDecision::kAccepted;
  double translation_d2 = 0.0;  // squared Mahalanobis distance of the translation innovation
  double rotation_d2 = 0.0;     // same for the quaternion innovation
};

// The measured drift at one instant: D = world_from_head * inverse(xr_from_head).
SE3 measure_drift(const SE3& world_from_head, const SE3& xr_from_head);

// q or -q, whichever is closer to the reference (both are the same rotation); without this a
// measurement near the sign boundary would pull the filtered quaternion through zero.
Eigen::Vector4d align_quaternion_sign(const Eigen::Vector4d& q, const Eigen::Vector4d& reference);

// Starts the filter at one measurement with variance R.
DriftEstimate initialize_drift(const SE3& measured_drift, const DriftFilterOptions& options);

// Prediction with identity transition: P += Q * steps. `steps` is the number of global-pose
// periods since the last update (1 normally; more after a gap, so the filter trusts the next
// measurement more and its gate widens with the uncertainty that really accumulated).
DriftEstimate predict_drift(DriftEstimate estimate, const DriftFilterOptions& options,
                            double steps = 1.0);

// Squared Mahalanobis distances of a measurement against a predicted state (physical scale).
double translation_mahalanobis2(const DriftEstimate& predicted, const Eigen::Vector3d& measured,
                                const DriftFilterOptions& options);
double rotation_mahalanobis2(const DriftEstimate& predicted, const Eigen::Vector4d& measured,
                             const DriftFilterOptions& options);

// Kalman correction with identity measurement, no gating; renormalizes the quaternion.
DriftEstimate correct_drift(const DriftEstimate& predicted, const SE3& measured_drift,
                            const DriftFilterOptions& options);

// One full step: initialize, or predict + gate + correct. The paper's filter is this with
// options.gating = false. The translation is gated where the global pose measured it:
// `gate_point` is the tracked device's position in the xr frame (xr_from_head's translation),
// and the innovation is that of D * gate_point. At D's origin instead, a rotation error of the
// measurement moves D's translation by the angle times the device's distance from the origin
// (0.005 rad at 20 m: 0.1 m), which translation_sigma (the noise of a global pose's position)
// does not describe, and good poses far from the origin are gated out.
DriftUpdate update_drift(const DriftEstimate& estimate, const SE3& measured_drift,
                         const DriftFilterOptions& options, double steps = 1.0,
                         const Eigen::Vector3d& gate_point = Eigen::Vector3d::Zero());

// Steady-state Kalman gain of the identity random-walk model: the fraction of each innovation
// that is applied once the filter has converged (documentation and tests).
double steady_state_gain(double process_noise, double measurement_noise);

}  // namespace coloc::fusion
