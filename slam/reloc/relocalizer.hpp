#pragma once
// Relocalization when tracking is lost (ORB-SLAM's Tracking::Relocalization): keyframe
// candidates from the BoW database, BoW matching against each, EPnP inside RANSAC on the 2D-3D
// matches, pose-only optimization, then a projection search of the candidate's points for more
// matches and a final optimization. The caller holds the map lock.
#include "slam/bow/database.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"
#include "slam/optim/pose_optimizer.hpp"

namespace coloc::slam::reloc {

struct RelocalizationOptions {
  std::size_t max_candidates = 10;
  int min_bow_matches = 15;
  int ransac_iterations = 300;
  double ransac_reprojection_px = 4.0;  // EPnP RANSAC inlier threshold (level-0 pixels)
  int min_ransac_inliers = 12;
  int min_inliers = 50;  // after optimization and projection search
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct RelocalizationResult {
  bool success = false;
  KeyframeId keyframe;  // the candidate that relocalized the frame
  int inliers = 0;
  int candidates = 0;
};

// On success `frame` has its pose and its inlier matches in frame.points (outliers cleared).
// The frame needs its BoW vector and feature vector.
RelocalizationResult relocalize(frame::Frame& frame, const map::Map& map,
                                const bow::BowDatabase& database,
                                const RelocalizationOptions& options = {});

}  // namespace coloc::slam::reloc
