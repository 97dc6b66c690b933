#include "fusion/drift_filter.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::fusion {
namespace {

void require_positive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw Error("must be a positive finite number, got " + std::to_string(value),
                ErrorContext{.field = std::string("DriftFilterOptions.") + field});
  }
}

Eigen::Vector4d coefficients(const SE3& pose) {
  const Eigen::Quaterniond& q = pose.quaternion();
  return {q.x(), q.y(), q.z(), q.w()};
}

// Scalar Kalman step for one part with identity models: returns the gain.
double kalman_gain(double predicted_variance, double measurement_noise) {
  return predicted_variance / (predicted_variance + measurement_noise);
}

}  // namespace

void DriftFilterOptions::check() const {
  require_positive(process_noise, "process_noise");
  require_positive(measurement_noise, "measurement_noise");
  require_positive(translation_sigma, "translation_sigma");
  require_positive(rotation_sigma, "rotation_sigma");
  require_positive(gate_chi2, "gate_chi2");
  if (reset_after_rejections < 1) {
    throw Error("must be at least 1",
                ErrorContext{.field = "DriftFilterOptions.reset_after_rejections"});
  }
}

SE3 DriftEstimate::drift() const {
  const Eigen::Quaterniond q(rotation[3], rotation[0], rotation[1], rotation[2]);
  return SE3(q, translation);
}

SE3 measure_drift(const SE3& world_from_head, const SE3& xr_from_head) {
  return world_from_head * xr_from_head.inverse();
}

Eigen::Vector4d align_quaternion_sign(const Eigen::Vector4d& q, const Eigen::Vector4d& reference) {
  return q.dot(reference) < 0.0 ? Eigen::Vector4d(-q) : q;
}

DriftEstimate initialize_drift(const SE3& measured_drift, const DriftFilterOptions& options) {
  DriftEstimate e;
  e.initialized = true;
  e.translation = measured_drift.translation();
  e.rotation = coefficients(measured_drift);
  e.translation_variance = options.measurement_noise;
  e.rotation_variance = options.measurement_noise;
  return e;
}

DriftEstimate predict_drift(DriftEstimate estimate, const DriftFilterOptions& options,
                            double steps) {
  const double q = options.process_noise * std::max(steps, 1.0);
  estimate.translation_variance += q;
  estimate.rotation_variance += q;
  return estimate;
}

double translation_mahalanobis2(const DriftEstimate& predicted, const Eigen::Vector3d& measured,
                                const DriftFilterOptions& options) {
  const double scale =
      options.translation_sigma * options.translation_sigma / options.measurement_noise;
  const double s = (predicted.translation_variance + options.measurement_noise) * scale;
  return (measured - predicted.translation).squaredNorm() / s;
}

double rotation_mahalanobis2(const DriftEstimate& predicted, const Eigen::Vector4d& measured,
                             const DriftFilterOptions& options) {
  const double scale = options.rotation_sigma * options.rotation_sigma / options.measurement_noise;
  const double s = (predicted.rotation_variance + options.measurement_noise) * scale;
  const Eigen::Vector4d z = align_quaternion_sign(measured, predicted.rotation);
  return (z - predicted.rotation).squaredNorm() / s;
}

DriftEstimate correct_drift(const DriftEstimate& predicted, const SE3& measured_drift,
                            const DriftFilterOptions& options) {
  DriftEstimate e = predicted;
  const double kt = kalman_gain(predicted.translation_variance, options.measurement_noise);
  e.translation += kt * (measured_drift.translation() - predicted.translation);
  e.translation_variance = (1.0 - kt) * predicted.translation_variance;

  const Eigen::Vector4d z = align_quaternion_sign(coefficients(measured_drift), predicted.rotation);
  const double kr = kalman_gain(predicted.rotation_variance, options.measurement_noise);
  e.rotation += kr * (z - predicted.rotation);
  e.rotation.normalize();  // the linear update leaves the unit sphere slightly
  e.rotation_variance = (1.0 - kr) * predicted.rotation_variance;
  e.consecutive_rejections = 0;
  return e;
}

DriftUpdate update_drift(const DriftEstimate& estimate, const SE3& measured_drift,
                         const DriftFilterOptions& options, double steps,
                         const Eigen::Vector3d& gate_point) {
  DriftUpdate u;
  if (!estimate.initialized || estimate.consecutive_rejections >= options.reset_after_rejections) {
    u.estimate = initialize_drift(measured_drift, options);
    u.decision = GateDecision::kInitialized;
    return u;
  }
  const DriftEstimate predicted = predict_drift(estimate, options, steps);
  DriftEstimate at_point = predicted;  // the prediction moved to where the pose was measured
  at_point.translation = predicted.drift() * gate_point;
  u.translation_d2 = translation_mahalanobis2(at_point, measured_drift * gate_point, options);
  u.rotation_d2 = rotation_mahalanobis2(predicted, coefficients(measured_drift), options);
  if (options.gating &&
      (u.translation_d2 > options.gate_chi2 || u.rotation_d2 > options.gate_chi2)) {
    // A rejected measurement carries no information: keep the prior state (not the predicted
    // one, so a burst of outliers does not inflate P and open the gate for the next outlier).
    u.estimate = estimate;
    ++u.estimate.consecutive_rejections;
    u.decision = GateDecision::kRejected;
    return u;
  }
  u.estimate = correct_drift(predicted, measured_drift, options);
  u.decision = GateDecision::kAccepted;
  return u;
}

double steady_state_gain(double process_noise, double measurement_noise) {
  // Riccati fixed point of P' = P + Q, P = P' R / (P' + R): P'^2 - Q P' - Q R = 0.
  const double predicted =
      0.5 * (process_noise +
             std::sqrt(process_noise * process_noise + 4.0 * process_noise * measurement_noise));
  return predicted / (predicted + measurement_noise);
}

}  // namespace coloc::fusion
