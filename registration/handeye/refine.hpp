#pragma once
// Nonlinear refinement (beyond the paper): X = device_from_marker, vr_from_camera and, if asked,
// sigma are estimated jointly with Ceres by minimizing, per registration, the discrepancy between
// the measured camera_from_marker_i (translation times sigma) and its prediction
// vr_from_camera^-1 * vr_from_device_i * X. One residual per registration (not per pair) keeps
// the measurement errors independent, which the pair equations A_ij X = X B_ij are not.
// Residuals are normalized by the NoiseModel; rotations live on SO(3) (quaternion manifold).

#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

struct RefineResult {
  SE3 device_from_marker;
  SE3 vr_from_camera;
  double sigma = 1.0;
  bool converged = false;
  int iterations = 0;
  double variance_factor = 1.0;  // chi^2 / degrees of freedom of the normalized residuals
  // See Summary::device_from_marker_covariance (already multiplied by variance_factor).
  std::optional<Matrix6d> device_from_marker_covariance;
  std::optional<double> sigma_variance;
};

RefineResult refine(std::span<const Registration> registrations, const std::vector<bool>& used,
                    const SE3& device_from_marker, const SE3& vr_from_camera, double sigma,
                    const Options& options);

// Cramer-Rao bound of X = device_from_marker: the covariance (layout and units as
// Summary::device_from_marker_covariance) that bounds every unbiased estimator, from the Fisher
// information of refine()'s residuals evaluated at the given unknowns (the truth, in a
// simulation) with `noise` taken as the true noise (no rescaling by residuals). Empty when the
// information is singular or there are too few registrations.
std::optional<Matrix6d> cramer_rao_bound(std::span<const Registration> registrations,
                                         const std::vector<bool>& used,
                                         const SE3& device_from_marker, const SE3& vr_from_camera,
                                         double sigma, const NoiseModel& noise,
                                         bool estimate_scale = false);

// The noise model the residuals of a solution imply (variance component estimation): rotation,
// lateral and depth (along the viewing ray) standard deviations of the marker pose, corrected for
// the degrees of freedom, with the device terms folded in. Needs >= 3 used registrations.
NoiseModel noise_from_residuals(std::span<const Registration> registrations,
                                const std::vector<bool>& used, const SE3& device_from_marker,
                                const SE3& vr_from_camera, double sigma, int parameters);

// Rotation angle (rad) and translation distance (m) between the measured camera_from_marker
// (translation times sigma) and vr_from_camera^-1 * vr_from_device * device_from_marker.
std::pair<double, double> registration_residual(const Registration& registration,
                                                const SE3& device_from_marker,
                                                const SE3& vr_from_camera, double sigma);

}  // namespace coloc::registration::handeye
