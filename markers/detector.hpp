#pragma once
// Square fiducial detection (ArUco and AprilTag dictionaries) over OpenCV contrib's aruco module.
//
// Pixel and corner conventions: markers/observation.hpp.
//
// Keyframe use (issue 9, item 6): construct one MarkerDetector per SLAM system and call detect()
// on each keyframe's grey image. detect() is const and keeps no state between calls, so one
// detector may be shared by threads. `coloc bench markers` measures its cost per 640x480 frame.

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <opencv2/aruco.hpp>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "markers/observation.hpp"

namespace coloc::markers {

enum class CornerRefinement {
  kNone,       // integer-ish corners from the polygon fit
  kSubpixel,   // cv::cornerSubPix on the four corners (default: sub-pixel and cheap)
  kContour,    // line fit on the contour points
  kAprilTag,   // AprilTag 2 quad detection (slow; for AprilTag dictionaries)
  kEdgeLines,  // sub-pixel, then lines fitted to the four sides (edge_refine.hpp): the most
               // precise on undistorted images (scanner cube faces); falls back to kSubpixel
};

struct DetectorOptions {
  // OpenCV dictionary name (dictionary.hpp) or a custom dictionary .yml file.
  std::string dictionary = "DICT_4X4_50";
  CornerRefinement corner_refinement = CornerRefinement::kSubpixel;
  int refinement_window = 5;  // half window of the sub-pixel search, pixels
  int refinement_max_iterations = 30;
  double refinement_min_accuracy = 0.01;  // pixels
  // Smallest marker perimeter as a fraction of the image's larger side (OpenCV's
  // minMarkerPerimeterRate); 0.03 finds ~15 px markers in a 640 px image.
  double min_marker_perimeter_rate = 0.03;
  // Candidates closer than this fraction of their perimeter are merged and only the larger is
  // decoded (OpenCV's minMarkerDistanceRate, default 0.05 there). A printed marker with a white
  // margin of one cell on a darker wall gives such a larger square (the margin's outline); at
  // 0.05 it hides the marker, so the default is lower.
  double min_marker_distance_rate = 0.02;
  // ArUco 3 detection (Romero-Ramirez et al. 2018): thresholds a downscaled image; several times
  // faster on large frames, loses the smallest markers.
  bool aruco3 = false;
  // Optional OpenCV detector_params.yml (the format of aruco's tutorials). Its keys are applied
  // after the fields above and override them; an unknown key is an error naming it.
  std::filesystem::path parameters_file;

  // Throws coloc::Error naming the first bad field.
  void check() const;
};

class MarkerDetector {
 public:
  // Throws coloc::Error when the options are invalid, the dictionary is unknown, or the
  // parameters file is unreadable.
  explicit MarkerDetector(DetectorOptions options);

  // Detects markers in an 8-bit grey or BGR image. Results are ordered by id, then by x of the
  // centre. Several markers with the same id are all returned (the caller decides what a
  // duplicate means). Throws coloc::Error for an empty image or unsupported type.
  std::vector<MarkerObservation> detect(const cv::Mat& image) const;

  const DetectorOptions& options() const { return options_; }
  const cv::aruco::Dictionary& dictionary() const { return *dictionary_; }

 private:
  void refine_corners(const cv::Mat& grey, std::vector<std::vector<cv::Point2f>>& corners) const;

  DetectorOptions options_;
  cv::Ptr<cv::aruco::Dictionary> dictionary_;
  cv::Ptr<cv::aruco::DetectorParameters> parameters_;
};

// Reads an OpenCV detector_params.yml into `parameters`. Throws coloc::Error naming the file
// and key for unknown keys or values of the wrong type.
void read_detector_parameters(const std::filesystem::path& path,
                              cv::aruco::DetectorParameters& parameters);

// Draws the observations (outline, first corner marked, id) onto a BGR copy of `image`.
cv::Mat draw_observations(const cv::Mat& image, const std::vector<MarkerObservation>& observations);

}  // namespace coloc::markers
