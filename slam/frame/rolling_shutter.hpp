#pragma once
// Rolling-shutter compensation of keypoints. A rolling-shutter camera exposes its rows one after
// the other over `readout` seconds, so while the camera turns, each row sees the scene from a
// slightly different orientation; a global-shutter pose fitted to such an image is off by up to
// half the rotation during the readout (1 deg at 2 rad/s and 20 ms: the Kinect v1 of TUM fr1).
// Each keypoint's bearing is rotated to where it would have been seen at the time of the image's
// middle row, under the camera's angular velocity (in the camera frame). Rotation only: the
// translation during 20 ms moves a point at 2 m by well under a pixel at walking speed.
#include <Eigen/Core>

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

}  // namespace coloc::slam::frame
