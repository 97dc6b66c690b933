#pragma once
// Global bundle adjustment with the scanned marker corners held fixed (Michiels et al. 2024,
// section 4.4, eq. 4): every keyframe pose and map point of the map, the map points'
// reprojection terms as the SLAM's own global BA has them, plus one term per marker corner per
// keyframe that observed the marker: the reprojection of the FIXED scan corner M_j into keyframe
// k against the detected corner m_kj. The markers fix the gauge, so no keyframe is held (the
// map ends up in the scan's frame); start from a roughly aligned map (rough.hpp, transform.hpp).
//
// Robust kernel: Huber with delta = sqrt(huber_chi2) (sqrt(7.815), ORB-SLAM's) on both terms,
// applied to the whitened residual.
//
// Relative weighting (the paper: "the weight of the marker pose error is equally contributing"):
// a map-point observation at pyramid level l is whitened by 1 / sigma_l (sigma_0 = 1 px, sigma_l
// = 1.2^l); a marker corner by sqrt(marker_weight) / marker_sigma_px. With the defaults (1, 1 px)
// one marker corner weighs exactly as one level-0 keypoint's (u, v); the markers pull through
// their number of corner observations (4 per marker per keyframe), not through a larger weight.
// marker_weight scales the information of every corner (the Huber threshold stays on the
// whitened residual).
//
// Outliers: one pass over all terms; then, while some kept marker's RMS corner reprojection
// error (pixels) exceeds marker_gate_px, the marker to blame is found by leaving each kept marker
// out in turn (a pass from the initial map without it): the culprit is the one that, left out,
// disagrees itself while the others agree best. It is rejected and its leave-one-out solution
// kept, so the rejected marker's pull leaves no bend behind (a moved marker seen by many
// keyframes can drag the map until an innocent, less observed one shows the disagreement, so
// the marker with the largest residual is not necessarily the culprit). At most max_rounds
// markers are rejected, and never down to fewer than two. Last, map-point observations whose
// chi2 exceeds chi2_stereo / chi2_mono are dropped (as ORB-SLAM) and a final pass runs.
// Cost: one pass per kept marker for each rejection, nothing extra when the markers agree.
#include <ceres/sized_cost_function.h>

#include <array>
#include <map>
#include <unordered_set>
#include <vector>

#include "registration/align/ba_terms.hpp"
#include "slam/core/camera.hpp"
#include "slam/map/map.hpp"
#include "slam/optim/reprojection.hpp"

namespace coloc::registration::align {

struct MarkerBaOptions {
  int iterations = 20;         // Levenberg-Marquardt iterations per pass
  int max_rounds = 3;          // markers rejected at most (see the header)
  double huber_chi2 = 7.815;   // Huber delta = sqrt(huber_chi2), on both terms
  double chi2_stereo = 7.815;  // map-point outlier classification between passes
  double chi2_mono = 5.991;
  double marker_sigma_px = 1.0;  // standard deviation of a detected marker corner (pixels)
  double marker_weight = 1.0;    // multiplies each marker corner's information (>= 0)
  // Standard deviation of a scan-point observation (scan_points below; pixels): the 2-D/3-D
  // matches against the scan rendering are noisier than a keypoint (splats, rendering).
  double scan_point_sigma_px = 2.0;
  double marker_gate_px = 5.0;  // RMS corner reprojection (pixels) above which a marker is rejected
  int threads = 2;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct MarkerBaMarker {
  int id = -1;
  std::size_t keyframes = 0;  // keyframes whose observation entered the problem
  // RMS of |detected - projected scan corner| over its corner observations (pixels), before and
  // after; a rejected marker's final figure is measured in the final map all the same.
  double initial_rms_px = 0.0, final_rms_px = 0.0;
  bool rejected = false;
};

struct MarkerBaReport {
  std::size_t keyframes = 0, points = 0, observations = 0;
  std::size_t marker_observations = 0;  // corner terms (4 per marker per keyframe)
  std::size_t outliers = 0;             // map-point observations removed from the map
  std::vector<MarkerBaMarker> markers;  // by id
  // RMS reprojection (pixels) of the map points' kept observations, and of the accepted markers'
  // corners, before and after.
  double initial_point_rms_px = 0.0, final_point_rms_px = 0.0;
  double initial_marker_rms_px = 0.0, final_marker_rms_px = 0.0;
  int rounds = 0, iterations = 0;
  double ms = 0.0;
  std::vector<int> rejected_ids() const;
  // At least two markers were kept: the scan fixed the map's frame.
  bool usable() const;
};

// Scan corners by marker id (the frame the map comes out in), detector corner order.
using ScanCorners = std::map<int, std::array<Eigen::Vector3d, 4>>;

// Optimizes `map` in place. Markers used: those in `scan` observed by some keyframe, restricted
// to `use_ids` unless it is empty. Marker pixels are undistorted through `camera` (the intrinsics
// must match the keyframes' geometry). Throws coloc::Error for invalid options or a map with
// fewer than two keyframes.
// A pixel of a keyframe matched to a FIXED scan point (the point-cloud refinement's matches).
struct ScanPointObservation {
  KeyframeId keyframe;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // undistorted
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  // scan frame, metres
};

// Keyframes in `fixed_keyframes` keep their poses (held constant in both terms: the point-cloud
// refinement's accepted keyframes, refine.hpp); the others and every point move. `scan_points`
// add one term each, as a marker corner's with sigma scan_point_sigma_px and the same Huber
// kernel: the alternative to fixing poses that lets the matches of many keyframes average.
MarkerBaReport marker_bundle_adjustment(slam::map::Map& map, const ScanCorners& scan,
                                        const Camera& camera, const std::vector<int>& use_ids = {},
                                        const MarkerBaOptions& options = {},
                                        const std::unordered_set<KeyframeId>& fixed_keyframes = {},
                                        const std::vector<ScanPointObservation>& scan_points = {});

// The corner terms of the markers in `scan` (restricted to `use_ids` unless empty) seen by the
// window's keyframes, added to another global BA (surface_ba.hpp: markers and surface
// together); no marker is judged or rejected here. Returns the corner terms added.
std::size_t add_marker_corner_terms(ceres::Problem& problem, const slam::map::Map& map,
                                    const slam::mapping::BaWindow& window, const ScanCorners& scan,
                                    const Camera& camera, const std::vector<int>& use_ids,
                                    const MarkerBaOptions& options, PoseBlocks& poses);

// The marker term: residual = inv_sigma * (m_kj - Pi(C_k, M_j)) with M_j fixed; analytic
// Jacobian in the pose manifold's lifted form (slam/optim/bundle_adjustment.hpp). Exposed for
// the weighting and Jacobian tests.
class MarkerCornerCost : public ceres::SizedCostFunction<2, 7> {
 public:
  MarkerCornerCost(const slam::optim::Intrinsics& k, const Eigen::Vector2d& pixel,
                   const Eigen::Vector3d& corner, double inv_sigma)
      : k_(k), pixel_(pixel), corner_(corner), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  slam::optim::Intrinsics k_;
  Eigen::Vector2d pixel_;
  Eigen::Vector3d corner_;
  double inv_sigma_;
};

}  // namespace coloc::registration::align
