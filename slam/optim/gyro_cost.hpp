#pragma once
// The residual that ties two keyframes' relative rotation to what the gyro integrated between
// them (BundleProblem::Gyro):
//   r = log( (measured * exp(J * bias))^-1 * cam_a_from_world * world_from_cam_b ) / sigma,
// with `measured` the camera-frame rotation cam_a_from_cam_b integrated at zero bias and J its
// first-order change with the gyro bias (camera frame, rad/s) held at keyframe a. Vision's
// rotation errs most at corners (a few mrad in a few seconds on the twin building), where the
// gyro is best. Parameters: pose a, pose b (lifted Jacobians, as the reprojection costs) and
// the bias (3).
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "slam/core/so3.hpp"

namespace coloc::slam::optim {

class GyroCost : public ceres::SizedCostFunction<3, 7, 7, 3> {
 public:
  GyroCost(const SO3& measured, const Eigen::Matrix3d& bias_jacobian, double sigma)
      : measured_inv_(measured.inverse()), bias_jacobian_(bias_jacobian), inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  SO3 measured_inv_;
  Eigen::Matrix3d bias_jacobian_;
  double inv_sigma_;
};

// The gyro bias's random walk between two keyframes: r = (bias_b - bias_a) / sigma, sigma the
// walk over their interval (random_walk * sqrt(dt)).
class GyroBiasWalkCost : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  explicit GyroBiasWalkCost(double sigma) : inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double inv_sigma_;
};

}  // namespace coloc::slam::optim
