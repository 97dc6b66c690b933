#pragma once
// A seeded synthetic registration scene (COLMAP's habit: the generator lives in the library and
// feeds the tests): a camera walking along a corridor wall (x from 0 to `length`, looking at the
// wall y = wall_distance, z up), map points on a rough wall, square markers on it, and a SLAM
// map of that walk whose keyframe observations are the TRUE projections (plus noise) but whose
// poses and points carry a known drift field: a bend (yaw about z growing with x, as a drifting
// heading does) and a rigid offset slam_from_scan (the SLAM frame starts at its first keyframe,
// not at the scan's origin). Registration must undo both.
//
// Frames: "scan" is the true world (metres); the map is in "slam". Camera: 640x480 pinhole, f =
// 525, no distortion, bf = 40 (as TUM's). All keypoints at pyramid level 0 (sigma 1 px).
#include <cstdint>
#include <memory>
#include <unordered_map>

#include "markers/marker_map.hpp"
#include "registration/align/surface_ba.hpp"
#include "registration/render/scene.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

struct SyntheticRegistrationOptions {
  std::uint64_t seed = 1;
  double length = 16.0;            // metres walked along x
  double keyframe_spacing = 0.25;  // metres between keyframes
  double wall_distance = 2.5;      // metres from the walk (y = 0) to the wall
  double wall_relief = 0.5;        // points lie up to this far in front of the wall (metres)
  double points_per_m2 = 40.0;     // of wall (between z = -1.2 and z = 1.6)
  double marker_spacing = 2.0;     // metres between markers along the wall (first at x = 1)
  double marker_size = 0.2;        // edge length, metres
  double pixel_noise = 0.0;        // standard deviation of keypoints and marker corners (pixels)
  double depth_noise = 0.0;        // relative standard deviation of keypoint depths
  double bend_deg_per_m = 0.0;     // the drift field: yaw (degrees) accumulated per metre of x
  SE3 slam_from_scan;              // the SLAM frame's offset from the scan
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SyntheticRegistration {
  slam::map::Map map;  // the drifting SLAM map
  std::shared_ptr<const slam::frame::FrameGeometry> geometry;
  PinholeCamera camera;
  markers::MarkerMap scan_markers;  // the true corners, scan frame
  std::unordered_map<KeyframeId, SE3> true_cam_from_scan;
  std::unordered_map<MapPointId, Eigen::Vector3d> true_points;  // scan frame
};

// Deterministic for given options.
SyntheticRegistration make_synthetic_registration(const SyntheticRegistrationOptions& options);

// The drift field alone: maps a scan-frame point to where the drifting map holds it (bend, then
// slam_from_scan).
Eigen::Vector3d drift_point(const SyntheticRegistrationOptions& options, const Eigen::Vector3d& p);

// RMS distance (metres) between the map's keyframe centres and the true ones, in the frame the
// map is in now (no alignment): the co-location error once the map is registered.
double keyframe_centre_rms(const SyntheticRegistration& scene, const slam::map::Map& map);

// A scan of the scene for the surface BA: a small square patch (`patch_size` metres, points
// `spacing` apart) around every true map point, each turned by a seeded angle of up to 60
// degrees from facing the walk, so that the patches' normals constrain every direction.
render::PointCloud synthetic_scan_surface(const SyntheticRegistration& scene,
                                          double patch_size = 0.12, double spacing = 0.01,
                                          std::uint64_t seed = 1);

// What each keyframe's depth image would hold of that scan: the patch points in front of it and
// within its image, in its TRUE camera frame (the depth measures the real geometry), at most
// `per_keyframe`, spread over the patches.
KeyframeDepthSamples synthetic_depth_samples(const SyntheticRegistration& scene,
                                             const render::PointCloud& scan,
                                             std::size_t per_keyframe = 300);

}  // namespace coloc::registration::align
