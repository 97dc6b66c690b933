#include "slam/optim/gyro_cost.hpp"

#include <Eigen/Geometry>

namespace coloc::slam::optim {

namespace {
SO3 rotation_of(const double* pose) {  // [t, q(xyzw)] of cam_from_world
  return SO3(Eigen::Quaterniond(pose[6], pose[3], pose[4], pose[5]));
}
}  // namespace

bool GyroCost::Evaluate(double const* const* parameters, double* residuals,
                        double** jacobians) const {
  const SO3 a_from_b = rotation_of(parameters[0]) * rotation_of(parameters[1]).inverse();
  const Eigen::Map<const Eigen::Vector3d> bias(parameters[2]);
  const Eigen::Vector3d correction = -(bias_jacobian_ * bias);
  const SO3 q = measured_inv_ * a_from_b;  // the error before the bias correction
  const SO3 n = SO3::exp(correction) * q;  // = (measured * exp(J b))^-1 * a_from_b
  const Eigen::Vector3d e = n.log();
  Eigen::Map<Eigen::Vector3d> r(residuals);
  r = inv_sigma_ * e;
  if (!jacobians) return true;
  // Left perturbations of cam_from_world: R_a <- exp(pa) R_a, R_b <- exp(pb) R_b, so
  // a_from_b <- exp(pa) a_from_b exp(-pb) and n <- n exp(a_from_b^-1 pa) exp(-pb).
  const Eigen::Matrix3d jr_inv = SO3::right_jacobian_inverse(e);
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> j(jacobians[0]);
    j.setZero();
    j.block<3, 3>(0, 3) = inv_sigma_ * jr_inv * a_from_b.matrix().transpose();
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> j(jacobians[1]);
    j.setZero();
    j.block<3, 3>(0, 3) = -inv_sigma_ * jr_inv;
  }
  if (jacobians[2]) {
    // exp(c + dc) ~= exp(c) exp(Jr(c) dc) with dc = -J db, carried to the right through q.
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> j(jacobians[2]);
    j = -inv_sigma_ * jr_inv * q.matrix().transpose() * SO3::right_jacobian(correction) *
        bias_jacobian_;
  }
  return true;
}

bool GyroBiasWalkCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> a(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> b(parameters[1]);
  Eigen::Map<Eigen::Vector3d> r(residuals);
  r = inv_sigma_ * (b - a);
  if (!jacobians) return true;
  for (int k = 0; k < 2; ++k) {
    if (!jacobians[k]) continue;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> j(jacobians[k]);
    j = (k == 0 ? -inv_sigma_ : inv_sigma_) * Eigen::Matrix3d::Identity();
  }
  return true;
}

}  // namespace coloc::slam::optim
