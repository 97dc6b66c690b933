#pragma once
// Refinement of a marker-registered map against the scan's points (Michiels et al. 2024,
// section 4.5): each keyframe's stored features (map files keep keypoints and descriptors, not
// images) are matched against the scan rendered at the keyframe's pose (scan_match.hpp); a
// keyframe whose match is strong and whose PnP pose moves it plausibly little is accepted, and
// the marker bundle adjustment runs again with it. Two ways (hold_fixed): the paper's, the
// accepted keyframes set to their PnP poses and held fixed in both terms; or (the default) their
// inlier 2-D/3-D matches added as fixed-scan-point terms. On the twin a single keyframe's EPnP
// pose is only good to ~1.5 cm (the scan's splats are 2-4 cm at 3-6 m), so pinning keyframes
// there made the true pose error worse than the marker level (P50 0.99 -> 1.45 cm, building
// seed 1 with loop closing), while the terms let the matches of ~150 keyframes average with the
// map's own observations (0.99 -> 0.68 cm).
//
// Threads: keyframes are matched on `threads` worker threads, each with its own Renderer (an
// OSMesa context is current in one thread at a time; Renderer makes its own context current on
// every call) and its own ORB extractor; the renderers draw one render::SharedPointCloud, so the
// cloud's memory does not grow with the thread count. The result does not depend on it either.
// `progress` is called from the workers, one call at a time (serialized by a mutex).
#include <functional>
#include <optional>
#include <unordered_set>
#include <vector>

#include "registration/align/marker_ba.hpp"
#include "registration/align/scan_match.hpp"
#include "registration/render/scene.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

struct RefineOptions {
  ScanMatchOptions match;
  render::RenderOptions render;
  // A PnP pose farther than this from the keyframe's registered pose is not believed (the
  // markers already brought every keyframe within centimetres; metres, degrees).
  double max_correction_m = 0.25;
  double max_correction_deg = 3.0;
  int threads = 2;
  // Keyframes matched: every one (0), or only those at least `keyframe_spacing_m` from every
  // keyframe chosen before them (in id order) that looks within `keyframe_spacing_deg` of the
  // same way. A survey walk's keyframes are ~0.3 m apart and see mostly the same scan; at a
  // site's 1,456 keyframes matching all of them costs ~20 min on 2 cores, while the BA needs
  // the scan's pull spread over the map, not repeated in each place.
  double keyframe_spacing_m = 0.0;
  double keyframe_spacing_deg = 20.0;
  // Render-match-PnP passes per keyframe; each later pass renders at the previous PnP pose.
  int iterations = 2;
  bool bundle_adjust = true;  // false: only set the accepted poses
  // How the accepted keyframes enter the BA: held fixed at their PnP poses (the paper), or
  // (false) left free with their inlier matches as fixed-scan-point terms
  // (MarkerBaOptions::scan_point_sigma_px), so one keyframe's PnP noise does not pin it.
  bool hold_fixed = false;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct KeyframeRefinement {
  KeyframeId id;
  double timestamp = 0.0;
  MatchOutcome outcome = MatchOutcome::kTooFewRenderedFeatures;
  bool implausible = false;  // matched well but moved more than max_correction_*
  bool accepted = false;
  std::size_t image_features = 0, rendered_features = 0, matches = 0, inliers = 0;
  SE3 registered;  // cam_from_world before the refinement
  SE3 pnp;         // the PnP pose (meaningful when has_pose)
  bool has_pose = false;
  double correction_m = 0.0, correction_deg = 0.0;
  double median_offset_px = 0.0;  // 2-D distance at the registered pose (first pass's inliers)
  double rms_reprojection_px = 0.0;
  // The last pass's matches (inlier flags at the PnP pose; render_px in the rendering at the
  // previous pass's pose).
  std::vector<ScanCorrespondence> correspondences;
  double ms = 0.0;
  // "ok", an outcome_name(), or "implausible".
  std::string reason() const;
};

struct RefineReport {
  std::vector<KeyframeRefinement> keyframes;  // by id
  std::size_t accepted = 0;
  std::optional<MarkerBaReport> ba;
  double ms_match = 0.0, ms_ba = 0.0;
};

using RefineProgress = std::function<void(std::size_t done, std::size_t total)>;

// The ideal pinhole (no distortion) the keyframes' undistorted keypoints live in: fx fy cx cy of
// the map's frame geometry, the size of `camera`.
PinholeCamera ideal_camera(const slam::map::Map& map, const Camera& camera);

// One image to match against the scan: a keyframe's, or a frame localized in the map (the
// evaluation's test walk). `features` are undistorted (the ideal pinhole) and must outlive the
// call.
struct MatchView {
  KeyframeId id;  // invalid for a frame that is not a keyframe
  double timestamp = 0.0;
  const slam::features::OrbFeatures* features = nullptr;
  SE3 cam_from_world;  // the estimated pose the scan is rendered at
};

// Matches each view against `cloud` (results in the views' order). Throws coloc::Error for
// invalid options, an empty cloud or a view without features.
std::vector<KeyframeRefinement> match_views(const std::vector<MatchView>& views,
                                            const render::PointCloud& cloud,
                                            const PinholeCamera& camera,
                                            const RefineOptions& options = {},
                                            const RefineProgress& progress = {});

// The keyframes to match under `options`' spacing (all, by id, when keyframe_spacing_m is 0).
std::vector<KeyframeId> spaced_keyframes(const slam::map::Map& map, const RefineOptions& options);

// Matches every keyframe (or those in `only`, when not empty) against `cloud`; the map is not
// changed. Throws coloc::Error for invalid options, an empty map or cloud.
std::vector<KeyframeRefinement> match_keyframes(const slam::map::Map& map,
                                                const render::PointCloud& cloud,
                                                const PinholeCamera& camera,
                                                const RefineOptions& options = {},
                                                const RefineProgress& progress = {},
                                                const std::vector<KeyframeId>& only = {});

// The whole step on a map registered by its markers: match, set the accepted keyframes' PnP
// poses, then (bundle_adjust) the marker BA with them fixed. `scan`/`use_ids` as for
// marker_bundle_adjustment. With no accepted keyframe the map is left as it was and ba is empty.
RefineReport refine_with_point_cloud(slam::map::Map& map, const render::PointCloud& cloud,
                                     const ScanCorners& scan, const Camera& camera,
                                     const std::vector<int>& use_ids, const MarkerBaOptions& ba,
                                     const RefineOptions& options = {},
                                     const RefineProgress& progress = {});

}  // namespace coloc::registration::align
