#pragma once
// Glue between a Frame's matches and the pose-only optimizer. Caller holds the map lock.
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"
#include "slam/optim/pose_optimizer.hpp"

namespace coloc::slam::matching {

// Optimizes frame.cam_from_world against its matched points (and `prior`, when given); sets
// frame.outlier; returns the number of inliers.
int optimize_frame_pose(frame::Frame& frame, const map::Map& map,
                        const optim::PoseOptimizerOptions& options = {},
                        const optim::CentrePrior* prior = nullptr);

// Clears the matches flagged as outliers (and their flags).
void drop_outliers(frame::Frame& frame);

}  // namespace coloc::slam::matching
