#pragma once
// What the registration's global bundle adjustments share (marker_ba.hpp, surface_ba.hpp): the
// state Ceres changes, the map points' reprojection terms as the SLAM's own global BA has them
// (Huber kernel on the whitened residual), their chi2 classification and pixel RMS, and the
// write-back into the map.
#include <ceres/problem.h>

#include <cstdint>
#include <vector>

#include "slam/mapping/ba_window.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::registration::align {

// Every keyframe and point of the map as one window, keyframes in id order (a deterministic
// problem). Throws coloc::Error (field "keyframes") for fewer than two keyframes.
slam::mapping::BaWindow whole_map_window(const slam::map::Map& map);

// The values Ceres changes: 7 per pose (optim::pose_to_array) and the points.
struct BaState {
  std::vector<double> poses;
  std::vector<Eigen::Vector3d> points;

  static BaState of(const slam::optim::BundleProblem& problem);
  SE3 cam_from_world(std::uint32_t pose) const;
  double* pose_block(std::uint32_t pose) { return &poses[7 * static_cast<std::size_t>(pose)]; }
};

// Adds pose parameter blocks to a problem once each, with the pose manifold, constant when the
// window holds the pose fixed.
class PoseBlocks {
 public:
  PoseBlocks(ceres::Problem& problem, const slam::optim::BundleProblem& window, BaState& state)
      : problem_(problem), window_(window), state_(state), added_(window.poses.size(), 0) {}
  double* operator()(std::uint32_t pose);

 private:
  ceres::Problem& problem_;
  const slam::optim::BundleProblem& window_;
  BaState& state_;
  slam::optim::PoseManifold manifold_;  // the problem must not own it
  std::vector<std::uint8_t> added_;
};

// A problem whose pose manifolds PoseBlocks owns.
ceres::Problem::Options ba_problem_options();

// One reprojection term per observation not flagged in `skip`.
void add_reprojection_terms(ceres::Problem& problem, const slam::optim::BundleProblem& window,
                            const slam::optim::Intrinsics& k, const std::vector<std::uint8_t>& skip,
                            double huber_delta, BaState& state, PoseBlocks& poses);

// Runs Levenberg-Marquardt (sparse Schur); returns the iterations made.
int solve_ba(ceres::Problem& problem, int iterations, int threads);

// Chi2 classification of the observations as slam/optim (1 = outlier); `rms_px` (may be null):
// the pixel RMS of the others.
std::vector<std::uint8_t> classify_observations(const slam::optim::BundleProblem& window,
                                                const BaState& state,
                                                const slam::optim::Intrinsics& k,
                                                double chi2_stereo, double chi2_mono,
                                                double* rms_px);

// Pixel RMS of the (u, v) reprojection of the observations not flagged in `skip`.
double reprojection_rms_px(const slam::optim::BundleProblem& window, const BaState& state,
                           const slam::optim::Intrinsics& k, const std::vector<std::uint8_t>& skip);

// Writes `state` into the map, erasing the observations flagged in `outlier`.
void write_back(slam::map::Map& map, slam::mapping::BaWindow& window, const BaState& state,
                const std::vector<std::uint8_t>& outlier);

}  // namespace coloc::registration::align
