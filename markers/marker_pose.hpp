#pragma once
// The pose of one square marker from its four detected corners, by IPPE (Collins & Bartoli 2014,
// OpenCV's SOLVEPNP_IPPE_SQUARE) followed by Levenberg-Marquardt refinement.
//
// Marker frame: origin at the centre of the black square, x toward the marker's right edge
// (corner 0 -> corner 1), y toward its top edge (corner 3 -> corner 0), z out of the printed face
// (toward a viewer in front of it); metres. The corners of an edge length s are
//   0: (-s/2,  s/2, 0)   1: ( s/2,  s/2, 0)   2: ( s/2, -s/2, 0)   3: (-s/2, -s/2, 0).
//
// Ambiguity: a planar square seen under weak perspective has two poses that reproject almost
// equally well: the true one and its mirror about the line of sight (the tilt sign flips). IPPE
// returns both. We never silently keep one: MarkerPose carries both candidates and marks the
// result `ambiguous` when the worse one is still plausible; callers resolve it with what they know
// (a prior rotation via choose_closest(), or, in the scan, agreement between sightings; see
// sighting_fusion.hpp). Near-frontal views are the typical ambiguous case.

#include <array>
#include <optional>

#include "markers/detector.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::markers {

struct PoseOptions {
  double marker_size = 0.0;  // edge length of the black square, metres (required)
  bool refine = true;        // LM refinement of both IPPE candidates on the corner residuals
  // The alternative solution is "plausible" (the pose is ambiguous) when its RMS reprojection
  // error is below max(ambiguity_ratio * best error, ambiguity_error_px).
  double ambiguity_ratio = 4.0;
  double ambiguity_error_px = 0.5;

  // Throws coloc::Error naming the first bad field.
  void check() const;
};

struct PoseCandidate {
  SE3 camera_from_marker;
  double reprojection_error_px = 0.0;  // RMS over the 4 corners of |projected - detected|
};

struct MarkerPose {
  int id = -1;
  PoseCandidate best;         // the smaller reprojection error
  PoseCandidate alternative;  // IPPE's other solution (mirror about the line of sight)
  bool ambiguous = false;

  const SE3& camera_from_marker() const { return best.camera_from_marker; }
  double reprojection_error_px() const { return best.reprojection_error_px; }
  // Distance from the camera centre to the marker centre, metres.
  double distance() const { return best.camera_from_marker.translation().norm(); }
  // Rotation angle between the two candidates, radians (0 for an exactly frontal view).
  double candidate_angle() const;
};

// The 4 corners in the marker frame (order above), metres.
std::array<Eigen::Vector3d, 4> marker_corners(double marker_size);

// RMS reprojection error (pixels) of the marker corners under `camera_from_marker`, using the
// full camera model (distortion included) against the detected corners. Infinity when a corner
// is behind the camera.
double reprojection_error(const Camera& camera, const SE3& camera_from_marker,
                          const MarkerObservation& observation, double marker_size);

// Solves both IPPE candidates. Distortion is removed from the corners first, so pinhole
// (radial-tangential) and Kannala-Brandt cameras both work. nullopt when a corner cannot be
// undistorted or no candidate puts the marker in front of the camera. Throws coloc::Error for
// invalid options.
std::optional<MarkerPose> estimate_marker_pose(const Camera& camera,
                                               const MarkerObservation& observation,
                                               const PoseOptions& options);

// Resolves an ambiguous pose with a prior rotation (e.g. the rotation predicted by tracking):
// returns `pose` with `best` being the candidate whose rotation is closer to the prior.
MarkerPose choose_closest(const MarkerPose& pose, const SO3& prior_camera_from_marker);

}  // namespace coloc::markers
