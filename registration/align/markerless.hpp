#pragma once
// A SLAM map registered to a scan without markers (`coloc register` without --markers):
// 1. rigid: the map's dense cloud, each keyframe's depth image placed at the keyframe's pose,
//    is registered to the scan's points (global_registration.hpp), and the whole map is moved
//    by the result;
// 2. surface (unless `options.surface` is off): the map's drift is bent out by the global BA
//    against the scan's surface (surface_ba.hpp), with a grid of each keyframe's depth pixels
//    as its pose's terms.
//
// The depth images come from one of two sources. Given the recording the map was built from
// (a `dataset::Sequence`), its frames at the keyframes' times: full resolution, with colour
// (which the global search uses to decide between shapes that fit alike). Without it (null),
// the small depth images the keyframes store (map::KeyframeDepth, maps saved since schema 4):
// a quarter of the resolution, no colour, and only the map file is needed.
#include <optional>
#include <string>

#include "registration/align/global_registration.hpp"
#include "registration/align/sequence_cloud.hpp"
#include "registration/align/surface_ba.hpp"
#include "slam/core/sim3.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

struct DepthSampleOptions {
  int stride_px = 16;                       // one depth pixel per stride x stride block
  double min_depth = 0.2, max_depth = 4.0;  // metres
  void check() const;
};

struct MarkerlessOptions {
  GlobalRegistrationOptions global;
  // A map with accelerometer windows (an IMU recording) is levelled by its gravity first, and
  // the global search then looks for yaw and translation only (the scan is z-up): one degree of
  // rotation instead of three, and two matches per RANSAC sample instead of three.
  bool map_gravity = true;
  SequenceCloudOptions map_cloud{.every = 1, .voxel_size = 0.02};
  bool surface = true;  // the surface BA after the rigid registration
  ScanSurfaceOptions scan_surface;
  DepthSampleOptions depth_samples;
  SurfaceBaOptions surface_ba;
  void check() const;
};

struct MarkerlessResult {
  // Where the keyframes' depth came from: the recording ("sequence") or the map ("map").
  std::string depth_source;
  GlobalRegistrationReport global;
  SequenceCloudStats map_cloud;
  std::size_t map_cloud_points = 0;
  Sim3 scan_from_slam;  // the rigid part (the surface BA bends the map further)
  // The map's up direction (slam frame) when the search used it (map_gravity), and from how
  // many keyframes' windows.
  std::optional<Eigen::Vector3d> up_slam;
  std::size_t gravity_windows = 0;
  std::optional<SurfaceBaReport> surface;
  std::size_t surface_points = 0;  // the scan's surface grid
  double ms_rigid = 0.0, ms_surface = 0.0;
};

// The map's keyframes fused at their poses: from `sequence` (the recording that built the map)
// when given, else from their stored depth (keyframes without one are left out and counted as
// unreadable frames; the points are grey). Throws coloc::Error when no keyframe has depth.
render::PointCloud map_dense_cloud(const slam::map::Map& map, const dataset::Sequence* sequence,
                                   const Camera& camera, const SequenceCloudOptions& options,
                                   SequenceCloudStats* stats = nullptr);

// How many of the map's keyframes store no depth image (Keyframe::depth).
std::size_t keyframes_without_depth(const slam::map::Map& map);
// What register_map_markerless checks first: without `sequence` (null), every keyframe must
// store its depth. Throws coloc::Error with field "--sequence" otherwise.
void check_depth_source(const slam::map::Map& map, const dataset::Sequence* sequence);

// The direction against gravity in the map's frame, from its keyframes' accelerometer windows
// (slam/map/inertial.hpp): each window's specific force turned into the world frame, less the
// camera's own acceleration there, is gravity's reaction, pointing up. Their mean direction;
// none when fewer than `min_windows` keyframes have a window, or when they disagree (the mean
// of the unit vectors shorter than 0.98: more than about 10 degrees of spread). `windows` (may
// be null) gets how many were used.
std::optional<Eigen::Vector3d> map_up_direction(const slam::map::Map& map,
                                                std::size_t min_windows = 5,
                                                std::size_t* windows = nullptr);

// A grid of each keyframe's depth pixels in its camera frame (one per stride_px x stride_px
// block of the full-resolution image), read from `sequence` when given, else from the keyframes'
// stored depth (the stored pixel nearest each grid position, at its own full-resolution pixel).
// Keyframes whose frame is missing or unreadable, or that store no depth, get none.
KeyframeDepthSamples keyframe_depth_samples(const slam::map::Map& map,
                                            const dataset::Sequence* sequence, const Camera& camera,
                                            const DepthSampleOptions& options = {});

// Registers `map` in place onto `scan_cloud`. `sequence` may be null when every keyframe stores
// its depth (otherwise a coloc::Error with field "--sequence", before any work). `initial`
// (scan_from_slam) skips the global search. Throws coloc::Error as register_clouds does (field
// "registration").
MarkerlessResult register_map_markerless(slam::map::Map& map, const dataset::Sequence* sequence,
                                         const Camera& camera, const render::PointCloud& scan_cloud,
                                         const MarkerlessOptions& options = {},
                                         const std::optional<SE3>& initial = std::nullopt);

// The result as one JSON document (level "cloud" or "surface", transform, verdict figures, the
// surface BA's rounds, times): what `coloc register` stores in the map and prints with --json.
std::string markerless_json(const MarkerlessResult& result);

}  // namespace coloc::registration::align
