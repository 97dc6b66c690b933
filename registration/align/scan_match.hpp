#pragma once
// One camera image's features matched against the laser scan rendered at the image's estimated
// pose (Michiels et al. 2024, section 4.5 and the evaluation of section 6): ORB features are
// extracted from the rendering, each image feature is matched to the rendered features near the
// same pixel (the pose estimate is already close: the search radius bounds the misalignment),
// each match takes the 3-D scan point behind its rendered pixel, and EPnP + RANSAC gives the
// pose of the camera in the scan's frame from those 2-D/3-D pairs; Levenberg-Marquardt on the
// inliers refines it.
//
// Frames and units: image pixels are undistorted (the ideal pinhole of `camera`, as keyframes
// store them), the rendering is made with that same ideal pinhole; world = the scan's frame
// (metres); poses cam_from_world.
//
// The 3-D point of a rendered feature is where its pixel's ray meets the plane of the splats
// around it (scan_match.cpp says why). Rendered features on a silhouette (the 5x5 neighbourhood
// mixes surfaces whose depths differ by more than max_depth_step, relative) give no 3-D point:
// the point behind such a feature belongs to the foreground or the background by chance.
#include <vector>

#include "registration/render/renderer.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::registration::align {

struct ScanMatchOptions {
  slam::features::ExtractorOptions orb{.n_features = 2000};  // features of the rendering
  double search_radius_px = 40.0;  // image feature vs rendered feature, at the estimated pose
  int max_level_difference = 2;    // pyramid levels between the two features of a match
  int max_hamming = 70;            // of 256 bits
  double ratio = 0.9;              // best / second best distance within the radius
  double max_depth_step = 0.05;    // relative depth spread of a usable rendered 5x5 patch
  double ransac_reprojection_px = 3.0;
  int ransac_iterations = 500;
  double ransac_confidence = 0.999;
  double inlier_px = 2.0;  // inliers after the LM refinement (pixels)
  int min_inliers = 30;    // fewer: the match is weak
  double min_inlier_ratio = 0.2;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

enum class MatchOutcome {
  kOk,
  kTooFewRenderedFeatures,  // the rendering is (nearly) empty at this pose
  kTooFewMatches,           // fewer than min_inliers matches with a 3-D point
  kPnpFailed,               // RANSAC found no pose
  kTooFewInliers,           // fewer than min_inliers
  kLowInlierRatio,          // inliers / matches below min_inlier_ratio
};
const char* outcome_name(MatchOutcome outcome);

struct ScanCorrespondence {
  Eigen::Vector2d image_px;   // the image feature (undistorted pixel)
  Eigen::Vector2d render_px;  // the matched rendered feature
  Eigen::Vector3d world;      // scan point behind render_px (scan frame, metres)
  int distance = 0;           // Hamming
  bool inlier = false;        // of the final pose
};

struct ScanMatch {
  MatchOutcome outcome = MatchOutcome::kTooFewRenderedFeatures;
  std::size_t image_features = 0, rendered_features = 0;
  std::vector<ScanCorrespondence> matches;
  std::size_t inliers = 0;
  bool has_pose = false;  // cam_from_world was estimated (also when the match is weak)
  SE3 cam_from_world;     // the image's pose in the scan frame from PnP
  // Over the inliers: median |image_px - render_px| (the paper's 2-D distance: how far the
  // rendering at the estimated pose is off), and the RMS reprojection of the scan points at the
  // PnP pose (how well that pose explains them).
  double median_offset_px = 0.0;
  double rms_reprojection_px = 0.0;
  bool ok() const { return outcome == MatchOutcome::kOk; }
};

// `rendering` must come from rendering the scan with `camera` (no distortion) at the estimated
// pose `rendering_pose` (cam_from_world). `extractor` is used for the rendering's features (not
// thread-safe: one per thread). Throws coloc::Error for invalid options or when the rendering's
// size differs from the camera's.
ScanMatch match_to_rendering(const slam::features::OrbFeatures& image,
                             const render::RenderResult& rendering, const SE3& rendering_pose,
                             const PinholeCamera& camera, slam::features::OrbExtractor& extractor,
                             const ScanMatchOptions& options = {});

// Angle (degrees) and centre distance (metres) between two poses cam_from_world.
double pose_angle_deg(const SE3& a, const SE3& b);
double pose_distance_m(const SE3& a, const SE3& b);

}  // namespace coloc::registration::align
