#pragma once
// Global bundle adjustment that bends a map onto the scan's surface, without markers (issue:
// markerless co-location). A rigid registration (global_registration.hpp) leaves the map's
// drift; this BA removes it the way the marker BA does with marker corners, with the scan's
// surface as the fixed reference instead:
// - every keyframe pose and map point, with the map points' reprojection terms as the SLAM's
//   global BA has them;
// - per map point, its point-to-plane distance to the scan's surface (scan_surface.hpp);
// - per keyframe, the point-to-plane distances of a grid of its depth pixels (the keyframe's
//   own depth, placed by its pose): the terms that tie each pose to the scan the way ICP does,
//   where sparse ORB points alone sit on edges whose normals are poor;
// - optionally the marker corners of a marker registration (marker_ba.hpp), so markers and
//   surface work together.
// Nearest surface points are found again between rounds (the association changes as the map
// moves), with a gate that shrinks from round to round: wide first to pull drifted parts in,
// then tight so that clutter the scan does not share stops pulling. Every term has a Huber
// kernel on its whitened residual. The surface fixes the gauge: no keyframe is held.
#include <string>
#include <unordered_map>
#include <vector>

#include "registration/align/marker_ba.hpp"
#include "registration/align/scan_surface.hpp"
#include "slam/core/camera.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

// Points of each keyframe's depth image in its camera frame (metres).
using KeyframeDepthSamples = std::unordered_map<KeyframeId, std::vector<Eigen::Vector3d>>;

struct SurfaceBaOptions {
  std::vector<double> gates_m = {0.10, 0.06, 0.04, 0.03};  // one round per gate
  int iterations = 10;          // Levenberg-Marquardt iterations per round
  double point_sigma_m = 0.02;  // a map point's distance to the surface (depth noise + scan)
  double depth_sigma_m = 0.02;  // a depth sample's
  // A keyframe's depth samples share its depth errors, so together they count as at most this
  // many independent ones: a keyframe's pull on its pose does not grow with the sample count.
  double depth_samples_effective = 100.0;
  double huber_chi2 = 7.815;  // Huber delta = sqrt(huber_chi2), on every whitened residual
  double chi2_stereo = 7.815, chi2_mono = 5.991;  // map-point outliers before the last round
  int threads = 2;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SurfaceBaRound {
  double gate_m = 0.0;
  std::size_t point_terms = 0, depth_terms = 0;  // associated within the gate
  // Median |point-to-plane distance| (metres) of the associated depth samples (map points when
  // there are none), before and after the round's solve.
  double median_before_m = 0.0, median_after_m = 0.0;
  int iterations = 0;
};

struct SurfaceBaReport {
  std::size_t keyframes = 0, points = 0, observations = 0, depth_samples = 0;
  std::size_t marker_observations = 0;  // corner terms, with markers
  std::size_t outliers = 0;             // map-point observations removed from the map
  double initial_point_rms_px = 0.0, final_point_rms_px = 0.0;
  std::vector<SurfaceBaRound> rounds;
  double ms = 0.0;
};

// Markers to add as fixed terms (a marker registration's kept markers).
struct SurfaceBaMarkers {
  const ScanCorners* corners = nullptr;  // null: no marker terms
  std::vector<int> use_ids;              // empty: every marker in `corners`
  MarkerBaOptions options;
};

// Optimizes `map` (already in the scan's frame, roughly) in place. `samples` may be empty (map
// points only) or cover some keyframes. Throws coloc::Error for invalid options or a map with
// fewer than two keyframes.
SurfaceBaReport surface_bundle_adjustment(slam::map::Map& map, const ScanSurface& surface,
                                          const Camera& camera, const KeyframeDepthSamples& samples,
                                          const SurfaceBaOptions& options = {},
                                          const SurfaceBaMarkers& markers = {});

// The report as a JSON object: keyframes, points, observations, depth_samples,
// marker_observations, outliers, point_rms_px [before, after], rounds (gate_m, point_terms,
// depth_terms, median_distance_m [before, after], iterations) and ms.
std::string surface_ba_json(const SurfaceBaReport& report);

// The term n . (x - q) / sigma on a map point x (q, n fixed): exposed for the Jacobian tests.
class PointToPlaneCost : public ceres::SizedCostFunction<1, 3> {
 public:
  PointToPlaneCost(const Eigen::Vector3d& q, const Eigen::Vector3d& n, double inv_sigma)
      : q_(q), n_(n), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d q_, n_;
  double inv_sigma_;
};

// The term n . (world_from_cam * p - q) / sigma on a pose (cam_from_world, the lifted
// Jacobian of slam/optim), p a depth sample in the camera frame.
class DepthToPlaneCost : public ceres::SizedCostFunction<1, 7> {
 public:
  DepthToPlaneCost(const Eigen::Vector3d& p_cam, const Eigen::Vector3d& q, const Eigen::Vector3d& n,
                   double inv_sigma)
      : p_cam_(p_cam), q_(q), n_(n), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d p_cam_, q_, n_;
  double inv_sigma_;
};

}  // namespace coloc::registration::align
