#pragma once
// Rolling-shutter compensation of keypoints. A rolling-shutter camera exposes its rows one after
// the other over `readout` seconds, so while the camera turns, each row sees the scene from a
// slightly different orientation; a global-shutter pose fitted to such an image is off by up to
// half the rotation during the readout (1 deg at 2 rad/s and 20 ms: the Kinect v1 of TUM fr1).
// Each keypoint's bearing is rotated to where it would have been seen at the time of the image's
// middle row, under the camera's angular velocity (in the camera frame). Rotation only: the
// translation during 20 ms moves a point at 2 m by well under a pixel at walking speed.
#include <Eigen/Core>
#include <vector>

#include "slam/features/orb_extractor.hpp"

namespace coloc::slam::frame {

struct RollingShutter {
  double readout = 0.0;  // seconds from the first to the last row; 0 = global shutter
  int rows = 0;          // image height in pixels
};

// Moves the undistorted coordinates (ux, uy) of every keypoint; the detected pixel (x, y), where
// depth is looked up, stays. `omega_cam`: angular velocity of the camera, rad/s, camera frame,
// such that the rotation from the camera at t + tau to the camera at t is exp(omega * tau).
void compensate_rolling_shutter(features::OrbFeatures& features, const RollingShutter& shutter,
                                const Eigen::Vector3d& omega_cam, double fx, double fy, double cx,
                                double cy);

// One matched keypoint for estimating the rotation rate from the image itself: the map point in
// the camera frame (middle-row time), the keypoint's uncompensated undistorted pixel, its row
// time offset and 1 / sigma (pixels) of its level.
struct RateObservation {
  Eigen::Vector3d point_cam = Eigen::Vector3d::Zero();
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double tau = 0.0;
  double inv_sigma = 1.0;
};

// The rotation rate (rad/s, camera frame) that best explains the rows' shear: Gauss-Newton on
// the compensated reprojection error with a Gaussian prior (prior, prior_sigma rad/s), e.g. the
// rate between the last two poses. Returns the prior when the observations cannot tell.
Eigen::Vector3d estimate_rotation_rate(const std::vector<RateObservation>& observations,
                                       const Eigen::Vector3d& prior, double prior_sigma, double fx,
                                       double fy, double cx, double cy);

// tau of a keypoint detected on image row `row` (seconds from the middle row's time).
double row_time(double row, const RollingShutter& shutter);

}  // namespace coloc::slam::frame
