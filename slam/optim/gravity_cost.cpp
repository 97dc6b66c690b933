#include "slam/optim/gravity_cost.hpp"

#include <Eigen/Geometry>

#include "slam/core/so3.hpp"

namespace coloc::slam::optim {

bool GravityCost::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  // Pose block [t, q(xyzw)] of cam_from_world; only its rotation matters here.
  const Eigen::Quaterniond q(parameters[0][6], parameters[0][3], parameters[0][4],
                             parameters[0][5]);
  const Eigen::Matrix3d world_from_cam = q.normalized().toRotationMatrix().transpose();
  const Eigen::Map<const Eigen::Vector3d> up(parameters[1]);
  const Eigen::Map<const Eigen::Vector3d> bias(parameters[2]);
  const Eigen::Vector3d force = force_ - bias;
  Eigen::Map<Eigen::Vector3d> r(residuals);
  r = inv_sigma_ * (world_from_cam * force - accel_ - g_ * up);
  if (!jacobians) return true;
  if (jacobians[0]) {
    // cam_from_world <- exp(d) * cam_from_world turns world_from_cam into
    // world_from_cam * (I - [phi]x): d r / d phi = world_from_cam * [force]x; rho has no say.
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> j(jacobians[0]);
    j.setZero();
    j.block<3, 3>(0, 3) = inv_sigma_ * world_from_cam * SO3::hat(force);
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> j(jacobians[1]);
    j = -inv_sigma_ * g_ * Eigen::Matrix3d::Identity();
  }
  if (jacobians[2]) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> j(jacobians[2]);
    j = -inv_sigma_ * world_from_cam;
  }
  return true;
}

}  // namespace coloc::slam::optim
