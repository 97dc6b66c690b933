#pragma once
// Relocalization when tracking is lost (ORB-SLAM's Tracking::Relocalization): keyframe
// candidates from the BoW database, BoW matching against each, EPnP inside RANSAC on the 2D-3D
// matches, pose-only optimization, then up to two projection searches of the candidate's points
// for more matches, each followed by a pose optimization:
//   - a wide pass (wide_radius_px, Hamming <= wide_max_distance) when the BoW inliers are fewer
//     than min_inliers;
//   - a narrow pass (narrow_radius_px, Hamming <= narrow_max_distance) when the wide pass left
//     more than narrow_min_inliers but fewer than min_inliers; it uses the pose refined by the
//     wide pass, so it recovers points that the less accurate EPnP pose projected too far from
//     their keypoints, and it skips the points already matched (inliers or not).
// The frame is accepted with >= min_inliers inliers. The caller holds the map lock.
#include <limits>
#include <vector>

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
  int min_optimized_inliers = 10;  // after the first pose optimization, else next candidate
  int min_inliers = 50;            // to accept the pose (after the projection passes)
  // Projection passes. Radii are level-0 pixels, scaled by the predicted level's scale factor;
  // distances are Hamming distances between 256-bit ORB descriptors.
  double wide_radius_px = 10.0;
  int wide_max_distance = 100;  // ORB-SLAM's TH_HIGH
  int narrow_min_inliers = 30;  // the narrow pass runs when the wide pass left more than this
  double narrow_radius_px = 3.0;
  int narrow_max_distance = 64;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// What tracking knows of where a lost camera can be soon after its last tracked frame. A room
// with repeated textures relocalizes a frame at a look-alike place with as many inliers as the
// right one (the demo room: 203 inliers 1.9 m away). With a prior, a candidate whose pose lands
// farther than the camera can have moved is passed over instead of failing the frame, the
// keyframes around the last tracked place are tried besides the database's, and of the poses
// inside the bound the nearest wins (a look-alike can be inside it too).
struct RelocalizationPrior {
  std::vector<KeyframeId> keyframes;  // tried first, in this order
  Eigen::Vector3d world_centre = Eigen::Vector3d::Zero();
  double max_distance_m = std::numeric_limits<double>::infinity();  // from world_centre
};

struct RelocalizationResult {
  bool success = false;
  KeyframeId keyframe;  // the candidate that relocalized the frame
  int inliers = 0;      // final inliers (the pose's support)
  int candidates = 0;   // keyframes returned by the database query
  // Stages of the accepted candidate (all 0 on failure): matches found and inliers after the
  // optimization that followed each stage.
  int bow_matches = 0;
  int pnp_inliers = 0;
  int optimized_inliers = 0;  // after EPnP + pose optimization
  int wide_pass_matches = 0;
  int wide_pass_inliers = 0;
  int narrow_pass_matches = 0;
  int narrow_pass_inliers = 0;
  // Candidates that solved the frame farther from the prior's centre than it allows, and the
  // nearest of those distances (for the caller's log).
  int implausible = 0;
  double nearest_implausible_m = std::numeric_limits<double>::infinity();
};

// On success `frame` has its pose and its inlier matches in frame.points (outliers cleared).
// The frame needs its BoW vector and feature vector.
RelocalizationResult relocalize(frame::Frame& frame, const map::Map& map,
                                const bow::BowDatabase& database,
                                const RelocalizationOptions& options = {},
                                const RelocalizationPrior& prior = {});

// The projection passes alone, against one keyframe: `frame` holds a pose (cam_from_world) and
// its current matches (e.g. the EPnP inliers after pose optimization); runs the wide pass, then
// the narrow pass if the inliers call for it, and fills the *_pass_* fields and `inliers` of
// `result`. Returns the final inlier count; outliers stay flagged in frame.outlier. Exposed so
// tests can start the passes from a chosen pose.
int search_by_projection_passes(frame::Frame& frame, const map::Keyframe& keyframe,
                                const map::Map& map, const RelocalizationOptions& options,
                                RelocalizationResult& result);

}  // namespace coloc::slam::reloc
