#pragma once
// Reprojection residuals of RGB-D (stereo-like) and monocular observations with their analytic
// Jacobians, shared by the pose-only Gauss-Newton and the Ceres bundle adjustment.
//
// A stereo-like observation is (u, v, u_r) with u_r = u - bf / z (ORB-SLAM2's RGB-D mode); a
// monocular one is (u, v). Residual = observed - predicted (pixels). Poses cam_from_world;
// pose perturbations are left-multiplied: cam_from_world <- exp(delta) * cam_from_world, with
// delta ordered (rho, phi) as slam/core/se3.hpp.
#include <Eigen/Core>

namespace coloc::slam::optim {

// Pinhole intrinsics of the undistorted keypoints plus the virtual stereo baseline.
struct Intrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double bf = 0.0;  // baseline * fx, pixels * metres
};

// 3-row (stereo) or 2-row (monocular) residual of a camera-frame point. Returns false when the
// point is not in front of the camera (z <= 1e-6); residual and Jacobian are then undefined.
// d_residual_d_pcam: d r / d p_cam (3x3; for monocular only the top 2 rows are meaningful).
bool stereo_residual(const Intrinsics& k, const Eigen::Vector3d& p_cam, const Eigen::Vector3d& obs,
                     Eigen::Vector3d& residual, Eigen::Matrix3d* d_residual_d_pcam);
bool mono_residual(const Intrinsics& k, const Eigen::Vector3d& p_cam, const Eigen::Vector2d& obs,
                   Eigen::Vector2d& residual, Eigen::Matrix<double, 2, 3>* d_residual_d_pcam);

// A rolling-shutter observation (u, v, u_r) compensated with a readout time `delta` seconds
// longer than the one it was compensated with: the bearing of (u, v) turned by
// exp(shear * delta), u_r moved with u. `shear` (rad/s) is the camera's angular rate times the
// keypoint's row offset from the middle row as a fraction of the rows (slam/frame/rolling_shutter).
// d_obs_d_delta (may be null): the derivative at `delta`.
Eigen::Vector3d shutter_shifted(const Intrinsics& k, const Eigen::Vector3d& obs,
                                const Eigen::Vector3d& shear, double delta,
                                Eigen::Vector3d* d_obs_d_delta);

// d p_cam / d delta for the left perturbation: [I, -[p_cam]x] (3x6).
Eigen::Matrix<double, 3, 6> pcam_jacobian_pose(const Eigen::Vector3d& p_cam);

}  // namespace coloc::slam::optim
