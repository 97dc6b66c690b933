#pragma once
// Registration of two point clouds with no initial guess: a dense cloud of the SLAM map (in the
// map's frame) onto the laser scan, for maps without markers. With an initial guess (the
// user's, or a previous level's) only the refinement runs.
//
// 1. Both clouds are thinned by a voxel grid; normals and FPFH descriptors (Rusu 2009, PCL) are
//    computed on them.
// 2. Each map point is matched to the scan point with the nearest descriptor, kept when the
//    match is mutual.
// 3. RANSAC over those matches (our own, seeded: the same inputs give the same answer): three
//    matches whose pairwise distances agree within `edge_similarity` propose a rigid transform
//    (two suffice with `gravity`, where both clouds are z-up and only yaw and translation are
//    free); a proposal scores by the matches it explains. The best distinct proposals are kept.
// 4. Each kept proposal is refined by point-to-plane ICP, coarse to fine, and judged by its
//    fitness: the share of map points within `inlier_factor` voxels of the scan after it.
// 5. The verdict. The best refined proposal is accepted only when its fitness passes, and no
//    other solution far from it explains the map nearly as well: the other proposals, and
//    probes where a symmetric or repeated space would fit (the winner moved a metre along each
//    axis, turned half a turn), are refined too. A rival that fits the shape nearly as well is
//    overruled when the colours of the map's points and the scan's agree clearly better at the
//    winner (a bare room is symmetric in shape, rarely in what hangs on its walls). Otherwise a
//    coloc::Error says which test failed and what to do (an initial guess, or markers).
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "registration/render/scene.hpp"
#include "slam/core/se3.hpp"

namespace coloc::registration::align {

struct GlobalRegistrationOptions {
  double voxel_size = 0.05;     // metres: the grid features are computed on
  double normal_radius = 2.5;   // in voxels
  double feature_radius = 6.0;  // in voxels
  double inlier_factor = 1.5;   // inlier distance, in voxels (RANSAC and fitness)
  bool gravity = false;         // both clouds z-up: yaw + translation only
  // RANSAC samples; 0: 10,000 with gravity (2-point samples), 100,000 without (3-point: the
  // chance that a sample is all inliers falls with the cube of the inlier share). TUM fr1/rpy's
  // second half (13 keyframes, 789 matches) found no basin in 10,000 3-point samples and the
  // right one in 100,000, for 4 s more.
  int ransac_iterations = 0;
  double edge_similarity = 0.9;  // pairwise distances of a sample agree to this ratio
  int hypotheses = 8;            // distinct proposals refined and compared
  std::vector<double> icp_voxels = {0.05, 0.02};  // coarse to fine (metres)
  int icp_iterations = 30;                        // per level
  int icp_max_points = 60000;  // map points per ICP iteration, taken evenly (large maps)
  // Share of map points within the inlier distance of the scan after the refinement. Right fits
  // measured 0.75-0.82 (twin room and building, 7-Scenes halves); the twin room's map in the
  // twin building's scan (a similar room with the same wall textures elsewhere) 0.40.
  double min_fitness = 0.55;
  double ambiguity = 0.85;  // another solution with this share of the best's fitness
  // ... is still accepted when the colours decide: the winner's colour correlation (Scored in
  // the .cpp: grey levels of inlier pairs) is at least min_colour_correlation and exceeds the
  // rival's by colour_margin.
  double min_colour_correlation = 0.3;
  double colour_margin = 0.2;
  // Whatever the rivals, a result whose colours do not agree with the scan's (correlation below
  // this; right fits measured 0.67-0.96) is refused: the shape fits, the place does not.
  double min_colour_agreement = 0.1;
  double distinct_m = 0.5, distinct_deg = 10.0;  // what counts as another solution
  std::uint64_t seed = 1;
  // FPFH and the refinement of the proposals (0: one per core); the result does not depend on it.
  int threads = 0;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct GlobalRegistrationReport {
  SE3 scan_from_map;
  double fitness = 0.0;    // share of map points within the inlier distance of the scan
  double rmse = 0.0;       // of those points' distances (metres)
  double overlap = 0.0;    // share of the scan's voxels that map points land in
  double runner_up = 0.0;  // fitness of the best solution far from the accepted one (0: none)
  // Pearson correlation of the grey levels of inlier pairs, of the accepted solution and of the
  // runner-up (NaN: no colour to compare, or no runner-up).
  double colour_correlation = std::numeric_limits<double>::quiet_NaN();
  double runner_up_colour_correlation = std::numeric_limits<double>::quiet_NaN();
  bool decided_by_colour = false;  // the runner-up's fit alone would have made it ambiguous
  std::size_t map_points = 0, scan_points = 0, matches = 0;
  bool from_initial = false;  // the global search was skipped
  double ms = 0.0;
};

// `initial` (optional): scan_from_map to refine from, skipping the global search and the
// uniqueness test (the caller vouches for the basin). Throws coloc::Error (field
// "registration") when the result is weak or ambiguous, with the figures.
GlobalRegistrationReport register_clouds(const render::PointCloud& map_cloud,
                                         const render::PointCloud& scan_cloud,
                                         const GlobalRegistrationOptions& options = {},
                                         const std::optional<SE3>& initial = std::nullopt);

}  // namespace coloc::registration::align
