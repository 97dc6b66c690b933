#pragma once
// The residual that ties a keyframe's tilt to gravity (BundleProblem::Gravity): what the
// accelerometer measured over a short window, turned into the world by the pose, must equal the
// camera's mean acceleration there minus gravity:
//   r = (world_from_cam.R * (f_cam - bias) - accel_world - g * up) / sigma,
// (an accelerometer at rest reads g upwards) with `up` the unit vector against gravity in the world
// frame (ceres::SphereManifold<3>) and the accelerometer bias in the camera frame. Parameters: the
// pose block (lifted Jacobian, as the reprojection costs), up (3) and bias (3).
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

namespace coloc::slam::optim {

class GravityCost : public ceres::SizedCostFunction<3, 7, 3, 3> {
 public:
  GravityCost(const Eigen::Vector3d& specific_force_cam, const Eigen::Vector3d& accel_world,
              double gravity, double sigma)
      : force_(specific_force_cam), accel_(accel_world), g_(gravity), inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d force_;
  Eigen::Vector3d accel_;
  double g_;
  double inv_sigma_;
};

}  // namespace coloc::slam::optim
