#pragma once
// Localized poses anchored to the laser scan: each frame's depth image aligned to the scan's
// surface (point-to-plane ICP on a SurfaceGrid), starting from the localizer's pose.
//
// Why: a localized pose is only as good as the map it was localized in, and a map registered
// to the scan keeps the SLAM's shape error (on 7-Scenes 2-4 cm after the best alignment, as
// ORB-SLAM2's). The scan is the building's geometry as surveyed; a depth image aligned to it
// directly inherits the scan's accuracy wherever its view holds enough surface in three
// directions. KinectFusion tracks the same way against its own model.
//
// How: the first frame (or the first after a failure) starts at the visual pose and aligns
// coarse to fine (capture about 10 cm, a few degrees). Later frames start from the last
// anchored pose moved by the visual motion since that frame, so the anchor follows the scan
// and not the map, and align at the fine level only. A weak prior toward the visual pose holds
// the directions the view cannot fix (a camera facing one wall would slide along it). An
// alignment is refused, and the visual pose kept, when too few depth samples meet the surface,
// their RMS is too large, or the result moved further from its start or from the visual pose
// than the bounds below allow.
//
// Known limit: in a long corridor (the twin building) accepted alignments still slide along
// it by 5-10 cm at times; there the anchor is worse than the visual pose (4.7 -> 21.6 mm).
//
// Depth: the camera's, back-projected through its model (distortion included): for a sensor
// whose depth is registered to colour, the anchored pose is the colour camera's. For one whose
// depth is not (7-Scenes) it is the depth camera's, the one the depth image was taken by.
//
// Frames: poses world_from_cam, the scan's frame (= the registered map's world), metres.
#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"
#include "slam/localize/surface_grid.hpp"

namespace coloc::slam::localize {

struct ScanAnchorOptions {
  int stride_px = 8;  // depth samples on this grid (640x480: 4,800 at most)
  // At most this many of them, spread evenly over the image: the cost per frame stays about
  // 10 ms whatever share of the image has depth (7-Scenes ~2,000 valid, the twin 4,800).
  int max_samples = 5000;
  double min_depth_m = 0.2, max_depth_m = 5.0;
  // A sample's point-to-plane standard deviation: the scan and its surfel model, and the
  // depth's noise, which grows as z^2 (Kinect v1: 1.4 mm at 1 m, 23 mm at 4 m; a D455 is
  // of that order). Residuals beyond 1.5 sigma are down-weighted (Huber).
  double surface_sigma_m = 0.005;
  double depth_sigma_at_1m = 0.0015;
  // Cold start (coarse then fine) and tracking (fine) schedules: the correspondence gate of
  // each iteration, metres.
  std::vector<double> cold_gates{0.10, 0.10, 0.10, 0.10, 0.10, 0.10, 0.08,  0.08,  0.04,  0.04,
                                 0.04, 0.04, 0.03, 0.03, 0.03, 0.03, 0.025, 0.025, 0.025, 0.025};
  std::vector<double> tracking_gates{0.04, 0.04, 0.03, 0.025, 0.025, 0.025};
  // Iterations stop once a step moves the camera less than this (metres, and radians).
  double converged_step = 1e-4;
  // The prior toward the visual pose (standard deviations): ~nothing beside thousands of
  // samples on a surface, everything along a direction no surface constrains.
  double prior_sigma_m = 0.05, prior_sigma_rad = 0.05;
  // Acceptance.
  int min_inliers = 300;
  // Share of the frame's depth samples that must meet the surface: a scan of another room
  // still offers walls to some of them.
  double min_inlier_ratio = 0.5;
  double max_rms_m = 0.02;
  // How far an alignment may move its start: a cold one by the registration's error plus
  // (unregistered depth) the colour-depth offset, a tracking one by the visual motion's error
  // over one frame (a few mm). Further, it slid onto another surface (a scan 40 cm off the map
  // was "fitted" 22 cm away before the cold bound).
  double max_cold_offset_m = 0.15, max_cold_offset_rad = 0.10;
  double max_tracking_step_m = 0.05, max_tracking_step_rad = 0.05;
  // The anchored pose may leave the visual one this far: the visual pose drifts where it is
  // bridged by odometry (24 cm over 3 s on 7-Scenes), the anchored one stays; beyond these the
  // two no longer describe one camera.
  double max_offset_m = 0.25, max_offset_rad = 0.15;
  // Threads that share a frame's samples (0: one per core; 1: the caller's alone). The result
  // is the same for any count (up to the summation order of floating point).
  int threads = 2;
  SurfaceGridOptions grid;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// The depth samples of a camera's images: a grid of pixels and their rays (z = 1), through the
// camera's model (distortion included).
class DepthSampler {
 public:
  DepthSampler(const Camera& camera, int stride_px);
  // Camera-frame points of the grid's pixels with a depth in [min_m, max_m] (CV_32FC1 metres,
  // the camera's size). Throws coloc::Error for another size or type.
  std::vector<Eigen::Vector3d> points(const cv::Mat& depth, double min_m, double max_m) const;
  std::size_t size() const { return pixels_.size(); }

 private:
  int width_, height_;
  std::vector<Eigen::Vector2i> pixels_;
  std::vector<Eigen::Vector3d> rays_;
};

struct AnchorResult {
  SE3 world_from_cam;
  int inliers = 0;     // depth samples within the last gate of a surfel
  int samples = 0;     // valid depth samples
  double rms_m = 0.0;  // point-to-plane RMS of the inliers
  int iterations = 0;
  // Smallest eigenvalue of the samples' translation information over their summed weight (the
  // weighted mean of n n^T: up to 1/3): near 0 when the view constrains a direction poorly (one
  // wall), which the prior then holds.
  double conditioning = 0.0;
};

class ScanAnchor {
 public:
  // `scan_points`: the scan in the map's world frame (a registered map's "scan" frame).
  // Throws coloc::Error for invalid options or a scan without planar surface.
  ScanAnchor(const std::vector<Eigen::Vector3f>& scan_points, ScanAnchorOptions options = {});

  // Aligns one frame's depth samples (camera frame, DepthSampler::points) to the scan from
  // `start_world_from_cam`; `cold` selects the coarse-to-fine schedule. nullopt when the
  // alignment is refused (see above); `visual_world_from_cam` is the pose it is checked against.
  // Const: one anchor may serve several localizers.
  std::optional<AnchorResult> align(const std::vector<Eigen::Vector3d>& samples,
                                    const SE3& start_world_from_cam,
                                    const SE3& visual_world_from_cam, bool cold) const;

  const SurfaceGrid& grid() const { return grid_; }
  const ScanAnchorOptions& options() const { return options_; }

 private:
  ScanAnchorOptions options_;
  SurfaceGrid grid_;
};

}  // namespace coloc::slam::localize
