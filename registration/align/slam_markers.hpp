#pragma once
// Marker corners in the SLAM map's frame: every keyframe's marker observations lifted to 3-D and
// fused across keyframes (Michiels et al. 2024, section 4.4: the SLAM side of the marker
// correspondences that rough alignment needs).
//
// Keyframes keep their features' depths but no depth image, so a corner is lifted by the
// marker's known edge length: IPPE (markers/marker_pose.hpp) gives camera_from_marker, the
// keyframe pose takes it to the world. The per-keyframe sightings are fused robustly as the scan
// side fuses its sightings (markers/sighting_fusion.hpp: median centre, MAD gate, IPPE ambiguity
// resolved by agreement), then each corner is triangulated from its pixel in every keyframe that
// saw it (Gauss-Newton on the reprojection error with fixed keyframe poses, observations above
// `max_reprojection_px` dropped): with several keyframes this is far more precise than the depth
// a 17 cm marker's PnP gives at a few metres.
//
// Frames and units: corners in the map's world frame (metres); pixels are the detector's raw
// (distorted) pixels, undistorted through `camera`.
#include <map>
#include <string>
#include <vector>

#include "markers/marker_map.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/ids.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

struct SlamMarkerOptions {
  // Edge length (metres) when a keyframe does not state one (Keyframe::marker_size == 0).
  double marker_size = 0.0;
  // Sightings farther than this (camera centre to marker centre, metres) are not used: the
  // corners of a marker a few tens of pixels wide are not worth fusing.
  double max_distance = 6.0;
  // Per-keyframe IPPE poses whose corner reprojection RMS exceeds this are dropped (pixels).
  double max_pose_error_px = 2.0;
  // Robust fusion of the per-keyframe corner sets (min_gate in metres).
  double fusion_min_gate = 0.03;
  double fusion_mad_factor = 3.0;
  // Multi-view triangulation of each corner (0 iterations: keep the fused corners).
  int triangulation_iterations = 10;
  double max_reprojection_px = 4.0;  // observations above this after triangulating are dropped
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SlamMarker {
  int id = -1;
  std::array<Eigen::Vector3d, 4> corners{};  // world (the map's frame), detector corner order
  double edge_length = 0.0;                  // metres
  std::vector<KeyframeId> keyframes;         // every keyframe that observed it
  int sightings = 0;                         // keyframe sightings fused (after the gate)
  int rejected_sightings = 0;
  // RMS distance (metres) of the fused sightings' corners to the fused corners.
  double fusion_residual = 0.0;
  // RMS reprojection error (pixels) of `corners` in the keyframes kept by triangulation (-1
  // when it was not triangulated: one usable keyframe or triangulation disabled).
  double reprojection_rms_px = -1.0;
  bool triangulated = false;
  Eigen::Vector3d centre() const;
};

struct SlamMarkers {
  std::map<int, SlamMarker> markers;  // by id
  // Observations that gave no usable sighting (pose failed, too far, too large an error).
  std::size_t unusable_observations = 0;
};

// Lifts and fuses every marker observation of `map`. A marker all of whose observations are
// unusable is left out (and counted). Throws coloc::Error for invalid options, or when a keyframe
// with markers has no edge length and options.marker_size is 0 (naming the keyframe).
SlamMarkers slam_marker_corners(const slam::map::Map& map, const Camera& camera,
                                const SlamMarkerOptions& options = {});

// "id 3 in keyframes 12, 14, 17 (3 sightings); id 5 in keyframe 40 (1 sighting)": what the
// error messages of rough alignment say about where markers were seen.
std::string describe_sightings(const SlamMarkers& markers);

}  // namespace coloc::registration::align
