#pragma once
// Pose-only optimization (ORB-SLAM's Optimizer::PoseOptimization), hand-written Gauss-Newton:
// the camera pose is refined against fixed 3-D points with a Huber kernel; after each of
// `rounds` rounds every observation is classified inlier/outlier by its chi2 (7.815 for 3-dof
// stereo-like, 5.991 for 2-dof monocular at 95 %), outliers are left out of the next round and
// the kernel is dropped in the last round. Pure function; thread-safe.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "slam/core/se3.hpp"
#include "slam/optim/reprojection.hpp"

namespace coloc::slam::optim {

struct PoseObservation {
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  // fixed point, metres
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // undistorted keypoint
  double u_right = -1.0;                            // < 0: monocular observation
  double inv_sigma2 = 1.0;                          // 1 / scale^2 of the keypoint's level
};

struct PoseOptimizerOptions {
  int rounds = 4;
  int iterations = 10;  // Gauss-Newton iterations per round
  double chi2_stereo = 7.815;
  double chi2_mono = 5.991;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// A prior on where the camera centre is (world frame, metres): where the motion model puts it.
// Its residual is the centre's offset over `sigma_m`, in the same whitened units as a keypoint's
// reprojection error. It leaves the rotation free (to first order the centre does not depend on
// it), so a fast turn is tracked as before.
struct CentrePrior {
  Eigen::Vector3d world_centre = Eigen::Vector3d::Zero();
  double sigma_m = 0.01;
};

struct PoseOptimizationResult {
  SE3 cam_from_world;
  std::vector<std::uint8_t> outlier;  // per observation
  int inliers = 0;
};

PoseOptimizationResult optimize_pose(const SE3& initial_cam_from_world,
                                     const std::vector<PoseObservation>& observations,
                                     const Intrinsics& intrinsics,
                                     const PoseOptimizerOptions& options = {},
                                     const CentrePrior* prior = nullptr);

}  // namespace coloc::slam::optim
