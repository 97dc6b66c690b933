#include "slam/optim/reprojection.hpp"

#include "slam/core/so3.hpp"

namespace coloc::slam::optim {

bool stereo_residual(const Intrinsics& k, const Eigen::Vector3d& p, const Eigen::Vector3d& obs,
                     Eigen::Vector3d& residual, Eigen::Matrix3d* jac) {
  if (p.z() <= 1e-6) return false;
  const double iz = 1.0 / p.z(), iz2 = iz * iz;
  const double u = k.fx * p.x() * iz + k.cx;
  const double v = k.fy * p.y() * iz + k.cy;
  residual = Eigen::Vector3d(obs.x() - u, obs.y() - v, obs.z() - (u - k.bf * iz));
  if (jac) {
    *jac << -k.fx * iz, 0.0, k.fx * p.x() * iz2,  //
        0.0, -k.fy * iz, k.fy * p.y() * iz2,      //
        -k.fx * iz, 0.0, k.fx * p.x() * iz2 - k.bf * iz2;
  }
  return true;
}

bool mono_residual(const Intrinsics& k, const Eigen::Vector3d& p, const Eigen::Vector2d& obs,
                   Eigen::Vector2d& residual, Eigen::Matrix<double, 2, 3>* jac) {
  if (p.z() <= 1e-6) return false;
  const double iz = 1.0 / p.z(), iz2 = iz * iz;
  residual =
      Eigen::Vector2d(obs.x() - (k.fx * p.x() * iz + k.cx), obs.y() - (k.fy * p.y() * iz + k.cy));
  if (jac) {
    *jac << -k.fx * iz, 0.0, k.fx * p.x() * iz2,  //
        0.0, -k.fy * iz, k.fy * p.y() * iz2;
  }
  return true;
}

Eigen::Vector3d shutter_shifted(const Intrinsics& k, const Eigen::Vector3d& obs,
                                const Eigen::Vector3d& shear, double delta,
                                Eigen::Vector3d* d_obs_d_delta) {
  const Eigen::Vector3d bearing((obs.x() - k.cx) / k.fx, (obs.y() - k.cy) / k.fy, 1.0);
  const Eigen::Vector3d q = SO3::exp(shear * delta) * bearing;
  const double iz = 1.0 / q.z();
  const double u = k.fx * q.x() * iz + k.cx;
  const double v = k.fy * q.y() * iz + k.cy;
  if (d_obs_d_delta) {
    const Eigen::Vector3d dq = shear.cross(q);  // d/d delta of exp(shear delta) * bearing
    const double du = k.fx * (dq.x() - q.x() * iz * dq.z()) * iz;
    const double dv = k.fy * (dq.y() - q.y() * iz * dq.z()) * iz;
    *d_obs_d_delta = Eigen::Vector3d(du, dv, du);
  }
  return {u, v, obs.z() + (u - obs.x())};
}

Eigen::Matrix<double, 3, 6> pcam_jacobian_pose(const Eigen::Vector3d& p_cam) {
  Eigen::Matrix<double, 3, 6> j;
  j.leftCols<3>().setIdentity();
  j.rightCols<3>() = -SO3::hat(p_cam);
  return j;
}

}  // namespace coloc::slam::optim
