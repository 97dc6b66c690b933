#pragma once
// What the viewer's page draws, as plain values: keyframes (pose, spanning-tree parent, loop
// edges, marker observations, reprojection residual), the strong covisibility edges, map points
// with their observation counts, marker corners (seen by SLAM, from the scan) and the scan's
// thinned points. Built from a Map under the caller's lock (scene_of copies only what is drawn,
// so a live viewer holds the tracking thread's lock for a short copy), serialized outside it.
//
// Frames and units: everything in the map's world frame (MapMetadata::frame_name), metres;
// poses world_from_cam; residuals in pixels.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::view {

struct SceneKeyframe {
  std::uint64_t id = 0;
  double timestamp = 0.0;
  SE3 world_from_cam;
  std::optional<std::uint64_t> parent;     // spanning tree
  std::size_t keypoints = 0, tracked = 0;  // tracked: keypoints with a map point
  std::size_t markers = 0;                 // marker observations
  // RMS reprojection error of the keyframe's map points (undistorted pixels); -1 without any.
  double residual_px = -1.0;
  // RMS of the scan's marker corners reprojected into this keyframe (raw pixels), where the
  // scan's markers are known and the keyframe saw one; -1 otherwise.
  double marker_residual_px = -1.0;
};

struct SceneMarker {
  int id = -1;
  std::array<Eigen::Vector3d, 4> corners{};  // detector order, world frame
};

struct ScenePoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::uint32_t> observations;  // keyframes observing each point
};

struct SceneOptions {
  int min_covisibility = 100;  // weights below this are not drawn (ORB-SLAM's viewer: 100)
  // Per-keyframe reprojection residuals: a projection per observation, too slow to run under
  // the lock of a large running map (live views leave them out).
  bool residuals = true;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct MapScene {
  std::string frame = "slam";                              // the map's frame name
  std::vector<SceneKeyframe> keyframes;                    // by id
  std::vector<std::array<std::uint64_t, 3>> covisibility;  // (a, b, weight), a < b
  std::vector<std::array<std::uint64_t, 2>> loop_edges;    // (a, b), a < b
  ScenePoints points;
  std::vector<SceneMarker> slam_markers, scan_markers;
  std::optional<PinholeCamera> camera;  // image size and intrinsics of the keyframes
};

// Copies what the page draws from `map` (call under the map's lock).
MapScene scene_of(const map::Map& map, const SceneOptions& options = {});

// Per-keyframe marker residuals against the scan's corners (by marker id), through `camera`
// (raw pixels, as the observations are).
void add_marker_residuals(MapScene& scene, const map::Map& map, const Camera& camera);

// The scene as the page reads it (GET /api/map): JSON, numbers rounded to what a view needs
// (0.1 mm, 1e-6 of a quaternion). `version` lets the page skip a scene it already has.
std::string scene_json(const MapScene& scene, std::uint64_t version);

// The page's keyframe panel (GET /api/keyframe/ID): image size, keypoints (raw pixels, tracked
// or not), marker observations (id, 4 corners), the pose and residual. Call under the map's lock.
std::optional<std::string> keyframe_json(const map::Map& map, std::uint64_t id);

}  // namespace coloc::slam::view
