#pragma once
// Rough alignment of the SLAM map to the scan (Michiels et al. 2024, section 4.4, eq. 3): the
// rigid (or similarity) transform scan_from_slam that best maps the SLAM map's marker corners
// onto the scanned ones, by Umeyama/Arun least squares, with outliers rejected by RANSAC over
// markers: every pair of common markers (eight corners, well conditioned when the two are apart)
// proposes a transform; a marker is an inlier when the RMS distance of its four corners after
// the transform is below `inlier_threshold`; the largest consensus (ties: smaller residual sum)
// is refitted on its inliers until the inlier set is stable.
//
// The threshold must exceed the map's drift between markers (rough alignment is rigid, the
// drift is not) and stay below the displacement to be caught; a marker moved between the scan
// and the mapping by less than the drift is left to the marker bundle adjustment (marker_ba.hpp),
// which rejects it by its reprojection error.
#include <map>
#include <string>
#include <vector>

#include "markers/marker_map.hpp"
#include "registration/align/slam_markers.hpp"
#include "slam/core/sim3.hpp"

namespace coloc::registration::align {

struct RoughOptions {
  double inlier_threshold = 0.35;  // metres, RMS corner distance of an inlier marker
  // Fewer common inlier markers than this is an error (2 is the least that fixes a rigid
  // transform well; with 2 nothing can be rejected).
  int min_markers = 3;
  // Pairs whose marker centres are closer than this (metres) propose no transform.
  double min_pair_distance = 0.5;
  bool estimate_scale = false;  // Sim3 instead of SE3 (RGB-D maps are metric)
  // Leave-one-out consistency: each marker's residual under the transform fitted to the OTHER
  // inliers; a marker is inconsistent when that exceeds max(consistency_min, consistency_factor
  // * the median of all markers' leave-one-out residuals). In a flexible (drifting, unclosed)
  // map the marker BA can bend the map to fit a moved marker at little cost, so a moved marker
  // must be caught here, where the map is still rigid: drift between markers is smooth and
  // small next to a marker moved by tens of centimetres.
  double consistency_min = 0.15;  // metres
  double consistency_factor = 3.0;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct MarkerResidual {
  int id = -1;
  double residual = 0.0;  // RMS corner distance after the alignment (metres)
  bool inlier = false;
  std::size_t keyframes = 0;   // SLAM keyframes that observed it
  double loo_residual = -1.0;  // leave-one-out residual (metres); -1 when not computable
  bool consistent = true;      // see RoughOptions::consistency_min
};

struct RoughAlignment {
  Sim3 scan_from_slam;
  std::vector<MarkerResidual> markers;  // every marker common to both sides, by id
  std::vector<int> only_in_slam;        // ids seen in the map but absent from the scan
  std::vector<int> only_in_scan;        // ids in the scan never seen by the map
  std::size_t inliers = 0;
  double rms = 0.0;  // RMS corner distance over the inliers (metres)
  std::vector<int> inlier_ids() const;
};

// Throws coloc::Error (field "markers") when fewer than options.min_markers markers are common
// to both sides, or when no transform has that many inliers; the message says which markers
// were seen where (describe_sightings) and, when inconsistent, each marker's best residual.
RoughAlignment rough_align(const SlamMarkers& slam, const markers::MarkerMap& scan,
                           const RoughOptions& options = {});

}  // namespace coloc::registration::align
