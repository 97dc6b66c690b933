#pragma once
// Geometric verification of a loop candidate for RGB-D, where the scale is known (ORB-SLAM's
// ComputeSim3 with the scale fixed): BoW matches between the new keyframe's keypoints and the
// candidate's points; SE3 by RANSAC on the 3-D/3-D pairs (keypoint depth in the new keyframe
// against the candidate's map point; Umeyama on 3 pairs, inliers by stereo-like reprojection
// chi2); pose refinement; a guided projection search of the candidate group's points; a second
// refinement; the same search from the new keyframe's own pose, taken instead when it finds
// enough of the group (a repeating texture verifies the place shifted by one period). Then the
// plausibility test: the correction this implies (new keyframe's estimated pose against the
// verified one) must be within what odometry can have drifted over the path between the two
// keyframes, or the place is only a look-alike. Last, with a camera and stored depth, the
// free-space test (free_space.hpp): the depth of the two places must agree.
//
// The caller holds the map lock (nothing is written).
#include <random>
#include <string>
#include <vector>

#include "slam/loop/loop_options.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::loop {

struct LoopVerification {
  bool accepted = false;
  std::string rejection;     // why not, when not accepted
  bool implausible = false;  // geometry verified, but the correction exceeds the drift bound
  bool look_alike = false;   // geometry verified and plausible, but the depth disagrees
  KeyframeId current, candidate;
  // The new keyframe's pose in the candidate's frame (the map as it was when the place was
  // first seen), and per keypoint of the new keyframe the candidate-side point it matched.
  SE3 corrected_cam_from_world;
  std::vector<MapPointId> matches;
  int bow_matches = 0, ransac_inliers = 0, inliers = 0;
  // The current-pose hypothesis (LoopOptions::current_pose_hypothesis): its inliers (0: not
  // run), and how far it moved the verified pose when it was taken (0: not taken).
  int current_pose_inliers = 0;
  double hypothesis_moved_m = 0.0;
  double path_m = 0.0;                        // path length between the two keyframes
  double correction_m = 0.0;                  // camera centre moved by the correction
  double correction_rad = 0.0;                // rotation of the correction
  double allowed_m = 0.0, allowed_rad = 0.0;  // the plausibility bounds at that path length
  FreeSpaceCount free_space;   // summed over the candidate's group, both ways (none: not run)
  double free_space_ms = 0.0;  // the free-space test's time (map locked)
};

// `depth_camera`: the camera of the keyframes' stored depth images, for the free-space test
// (nullptr: no free-space test).
LoopVerification verify_loop(const map::Map& map, KeyframeId current, KeyframeId candidate,
                             const LoopOptions& options, std::mt19937& rng,
                             const Camera* depth_camera);

// The free-space count of the keyframes `near_current`, moved into the candidate's frame by the
// loop's correction `candidate_world_from_world`, against the keyframes of `candidate_group`:
// every pair with stored depth, both ways. The new keyframe alone may see nothing but the
// matched wall; its neighbours see the rest of the room.
FreeSpaceCount free_space_against(const map::Map& map, const std::vector<KeyframeId>& near_current,
                                  const SE3& candidate_world_from_world,
                                  const std::vector<KeyframeId>& candidate_group,
                                  const Camera& camera, const FreeSpaceOptions& options);

// The plausibility test alone: the bounds at `path_m` (LoopVerification::allowed_m / _rad), and
// whether a correction of `correction_m` / `correction_rad` is within them.
bool plausible_correction(double correction_m, double correction_rad, double path_m,
                          const LoopOptions& options, double* allowed_m = nullptr,
                          double* allowed_rad = nullptr);

// Sum of the camera-centre steps between consecutive keyframes (by id) from `from` to `to`.
double path_length(const map::Map& map, KeyframeId from, KeyframeId to);

}  // namespace coloc::slam::loop
