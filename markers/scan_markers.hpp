#pragma once
// Marker positions from a laser scan's images (Michiels et al. 2024, section 4.3): for every
// image of an E57 file that has a pose (global_from_image), pinhole images directly and
// spherical / cylindrical panoramas as six cube faces, detect markers, solve image_from_marker by
// IPPE, reject detections whose reprojection error or range is too large, map the corners into
// the global frame as global_from_image * image_from_marker, and fuse the sightings per marker.
//
// E57 image conventions used (the digital twin writes the same): an image's pose maps its camera
// frame into the file-level frame; pinhole camera frame x right, y down, z forward, pixel centres
// at integers, fx = focalLength / pixelWidth, fy = focalLength / pixelHeight, principal point
// in pixels; panoramas as in panorama.hpp. visualReference images have no geometry and are
// skipped.

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "markers/detector.hpp"
#include "markers/marker_map.hpp"
#include "markers/marker_pose.hpp"
#include "markers/sighting_fusion.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::markers {

struct ScanMarkerOptions {
  DetectorOptions detector{.corner_refinement = CornerRefinement::kEdgeLines};
  PoseOptions pose;  // pose.marker_size is required
  double max_reprojection_error_px = 1.0;
  double max_distance = 3.0;  // metres, camera centre to marker centre
  int cube_face_size = 2048;  // pixels per face side for panoramas
  FusionOptions fusion;
  // When set, every searched image / cube face is written there as JPEG with the detections
  // drawn (green: accepted, red: rejected), for a person to look at.
  std::filesystem::path debug_dir;
  bool quiet = false;  // no progress bar on stderr

  // Throws coloc::Error naming the first bad field.
  void check() const;
};

// Why a detection did not become a sighting.
enum class Rejection { kNoPose, kReprojection, kDistance, kDuplicateId };
const char* to_string(Rejection r);

struct RejectedDetection {
  int id = -1;
  std::string image;
  Rejection reason = Rejection::kNoPose;
  double reprojection_error_px = 0.0;
  double distance = 0.0;
};

// The detections of one image: accepted sightings (global frame) and rejections.
struct ImageSightings {
  std::vector<Sighting> sightings;
  std::vector<RejectedDetection> rejected;
  std::vector<MarkerObservation> observations;  // every detection, for drawing
};

// Detects and posts the markers of one pinhole image whose pose is global_from_image. Markers
// whose id appears twice in the image are rejected (kDuplicateId): two physical markers with one
// id cannot be told apart.
ImageSightings sightings_in_image(const cv::Mat& image, const Camera& camera,
                                  const SE3& global_from_image, const std::string& name,
                                  const MarkerDetector& detector, const ScanMarkerOptions& options);

struct ScanMarkersResult {
  MarkerMap map;                            // the fused markers, with provenance
  std::vector<Sighting> sightings;          // every accepted sighting
  std::vector<RejectedDetection> rejected;  // every rejected detection
  int images_searched = 0;                  // pinhole images + panoramas (not faces)
  int faces_searched = 0;                   // images actually run through the detector
  std::vector<std::string> skipped;         // images without pose or geometry, with the reason
};

// Runs the whole extraction on an E57 file. Throws coloc::Error naming the file when it cannot
// be read or has no image with a pose and a usable representation (a clear message, not an empty
// success). No markers found is a result (an empty map), not an exception.
ScanMarkersResult scan_markers(const std::filesystem::path& e57_path,
                               const ScanMarkerOptions& options);

}  // namespace coloc::markers
