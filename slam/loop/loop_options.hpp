#pragma once
// Options of loop closing (slam/loop): detection, verification, the plausibility test that
// rejects perceptual aliasing, correction and the background global BA. Units: metres, radians,
// pixels (level 0), Hamming distances between 256-bit ORB descriptors.
#include <cstddef>

#include "slam/loop/free_space.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::loop {

struct LoopOptions {
  bool enabled = true;
  std::size_t queue_capacity = 8;  // keyframes waiting for the loop closer

  // Detection (ORB-SLAM's DetectLoop).
  std::size_t min_keyframes = 10;         // map size before any detection
  std::size_t keyframes_after_loop = 10;  // no detection this many keyframes after a correction
  std::size_t max_candidates = 5;         // groups returned by the BoW database per keyframe
  std::size_t group_neighbours = 10;      // covisible keyframes forming a candidate's group
  int min_consistency = 3;  // consecutive keyframes whose candidate groups must overlap

  // Geometric verification (SE3: RGB-D has metric scale).
  int min_bow_matches = 20;
  int ransac_iterations = 200;
  int min_ransac_inliers = 20;
  double projection_radius_px = 10.0;  // guided search around the RANSAC pose
  int projection_max_distance = 50;
  int min_inliers = 40;  // after guided search and pose refinement

  // The current-pose hypothesis: a wall paper, tiled floor or row of identical doors repeats, so
  // BoW and RANSAC can verify the candidate place shifted by one period (the twin site closed
  // two loops 2.0 m off along a corridor papered with a 2 m tile; the free-space test saw only
  // 1.2-1.8 % of samples in free space, since a shift along a wall keeps the wall's depth). The
  // new keyframe's own pose is the other hypothesis: the candidate group's points searched
  // around it and the pose refined. When that finds min_inliers, the place is already where the
  // map has it, within drift, and the loop is closed there with the small correction it
  // implies: of two verified poses a period apart, the one odometry agrees with is the true
  // one. (Its support is usually the smaller: the group was chosen for the shifted view, and
  // overlaps the true one only in part.) The first search around the current pose is wide
  // (drift of 0.1 m is 40 px at 1.3 m) but far narrower than a texture's period (2 m at 1.3 m
  // is 770 px). A true loop after drift beyond it finds few points around the drifted pose and
  // keeps its own hypothesis.
  bool current_pose_hypothesis = true;
  double current_pose_radius_px = 50.0;

  // Plausibility: a loop correction cannot exceed what odometry can have drifted over the
  // path between the two keyframes. Aliased places (a similar room elsewhere) need a
  // correction the size of the distance between them, so this is what rejects them. Measured
  // true loops: the twin building corrects 0.04-0.27 m / 0.004-0.016 rad after 84-85 m
  // (0.05-0.3 % of the path); fr1/rpy 0.098-0.108 m / 0.04-0.07 rad after 0.2-0.27 m. The
  // bounds: 0.12 m + 1.5 % of the path (5x the building's largest), 0.1 rad + 0.005 rad/m.
  // 3 %/m let a look-alike 1.95 m away through after 83 m of the building (1 of 6 runs
  // failed at 0.69 m ATE); 5 %/m and 0.02 rad/m a 3.8 m / 90 deg one after 80 m.
  double max_drift_m = 0.12;                // allowed translation at zero path length
  double max_drift_per_m = 0.015;           // plus this fraction of the path length
  double max_rotation_drift = 0.10;         // radians at zero path length
  double max_rotation_drift_per_m = 0.005;  // plus radians per metre of path

  // The free-space test (free_space.hpp), when the keyframes store depth and the closer knows
  // the camera: the new keyframe against the candidate's group, both ways. A loop whose
  // compared samples violate the other view's free space more often than this is a look-alike.
  // Measured share of samples in free space: true loops 0.002-0.016 % (twin site, 7 loops; twin
  // building 0.003 %), real 7-Scenes depth at the true pose 0.04-0.8 %; the site's look-alike
  // rooms (the same wall papers, other furniture) 8.4 %; a pose 0.3 m off 79-97 %.
  bool free_space_test = true;
  double max_free_space_violation = 0.04;
  int min_free_space_samples = 200;       // fewer compared samples: no verdict (the loop passes)
  std::size_t free_space_neighbours = 5;  // the new keyframe's covisible keyframes compared too
  FreeSpaceOptions free_space;

  // Correction.
  double fusion_radius_px = 4.0;
  int strong_covisibility = 100;  // covisibility edges of the essential graph
  int graph_iterations = 20;

  // Global BA of the whole map in the background after each correction (aborted by the next
  // loop or by stop()).
  bool global_ba = true;
  optim::BundleOptions ba{.iterations_robust = 10, .iterations_refine = 10};

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

}  // namespace coloc::slam::loop
