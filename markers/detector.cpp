#include "markers/detector.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "markers/dictionary.hpp"
#include "markers/edge_refine.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/yaml_text.hpp"

namespace coloc::markers {
namespace {

// Every key cv::aruco::DetectorParameters::readDetectorParameters understands (OpenCV 4.6).
constexpr std::array<const char*, 32> kParameterKeys{"adaptiveThreshWinSizeMin",
                                                     "adaptiveThreshWinSizeMax",
                                                     "adaptiveThreshWinSizeStep",
                                                     "adaptiveThreshConstant",
                                                     "minMarkerPerimeterRate",
                                                     "maxMarkerPerimeterRate",
                                                     "polygonalApproxAccuracyRate",
                                                     "minCornerDistanceRate",
                                                     "minDistanceToBorder",
                                                     "minMarkerDistanceRate",
                                                     "cornerRefinementMethod",
                                                     "cornerRefinementWinSize",
                                                     "cornerRefinementMaxIterations",
                                                     "cornerRefinementMinAccuracy",
                                                     "markerBorderBits",
                                                     "perspectiveRemovePixelPerCell",
                                                     "perspectiveRemoveIgnoredMarginPerCell",
                                                     "maxErroneousBitsInBorderRate",
                                                     "minOtsuStdDev",
                                                     "errorCorrectionRate",
                                                     "aprilTagQuadDecimate",
                                                     "aprilTagQuadSigma",
                                                     "aprilTagMinClusterPixels",
                                                     "aprilTagMaxNmaxima",
                                                     "aprilTagCriticalRad",
                                                     "aprilTagMaxLineFitMse",
                                                     "aprilTagMinWhiteBlackDiff",
                                                     "aprilTagDeglitch",
                                                     "detectInvertedMarker",
                                                     "useAruco3Detection",
                                                     "minSideLengthCanonicalImg",
                                                     "minMarkerLengthRatioOriginalImg"};
// Keys that OpenCV's own tutorial file (and other OpenCV versions) carry but 4.6 does not read:
// accepted with a warning so users' existing files load.
constexpr std::array<const char*, 4> kIgnoredKeys{"adaptiveThreshWinSize", "minMarkerDistance",
                                                  "cameraMotionSpeed", "useGlobalThreshold"};

// Sub-pixel search half-window as a fraction of the marker's cell size (measured on rendered,
// blurred markers of 20-150 px: 0.5 gives 0.2-0.4 px mean corner error; a fixed 5 px window gives
// 1.3 px on 30 px markers).
constexpr double kWindowPerCell = 0.5;

bool in_list(const std::string& key, const auto& list) {
  return std::any_of(list.begin(), list.end(), [&](const char* k) { return key == k; });
}

int refinement_method(CornerRefinement r) {
  switch (r) {
    case CornerRefinement::kNone:
      return cv::aruco::CORNER_REFINE_NONE;
    case CornerRefinement::kSubpixel:  // done by refine_corners(), with a cell-scaled window
    case CornerRefinement::kEdgeLines:
      return cv::aruco::CORNER_REFINE_NONE;
    case CornerRefinement::kContour:
      return cv::aruco::CORNER_REFINE_CONTOUR;
    case CornerRefinement::kAprilTag:
      return cv::aruco::CORNER_REFINE_APRILTAG;
  }
  return cv::aruco::CORNER_REFINE_NONE;
}

// One marker can be decoded twice: from the outer contour of its black border and from a
// contour inside it (the inner edge of the border, whose ring of data bits can pass as a border
// under error correction). Such detections share the id and the centre; the larger is the marker.
void remove_nested_duplicates(std::vector<MarkerObservation>& observations) {
  std::vector<bool> drop(observations.size(), false);
  for (std::size_t i = 0; i < observations.size(); ++i) {
    for (std::size_t j = i + 1; j < observations.size(); ++j) {
      const MarkerObservation& a = observations[i];
      const MarkerObservation& b = observations[j];
      if (a.id != b.id) continue;
      const double edge = 0.25 * std::max(a.perimeter(), b.perimeter());
      if ((a.centre() - b.centre()).norm() > 0.25 * edge) continue;
      drop[a.perimeter() < b.perimeter() ? i : j] = true;
    }
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (!drop[i]) observations[k++] = observations[i];
  }
  observations.resize(k);
}

}  // namespace

void DetectorOptions::check() const {
  if (dictionary.empty()) throw Error("must name a dictionary", {.field = "dictionary"});
  if (refinement_window < 1 || refinement_window > 50) {
    throw Error("must be in [1, 50] pixels", {.field = "refinement_window"});
  }
  if (refinement_max_iterations < 1) {
    throw Error("must be positive", {.field = "refinement_max_iterations"});
  }
  if (!(refinement_min_accuracy > 0.0)) {
    throw Error("must be positive", {.field = "refinement_min_accuracy"});
  }
  if (!(min_marker_perimeter_rate > 0.0 && min_marker_perimeter_rate < 4.0)) {
    throw Error("must be in (0, 4)", {.field = "min_marker_perimeter_rate"});
  }
  if (!(min_marker_distance_rate >= 0.0 && min_marker_distance_rate < 1.0)) {
    throw Error("must be in [0, 1)", {.field = "min_marker_distance_rate"});
  }
  if (!parameters_file.empty() && !std::filesystem::exists(parameters_file)) {
    throw Error("detector parameters file does not exist",
                {.file = parameters_file.string(), .field = "parameters_file"});
  }
}

namespace {

void read_parameters_text(const std::filesystem::path& path,
                          cv::aruco::DetectorParameters& parameters) {
  // Through the YAML guard (OpenCV's reader can loop forever on some malformed input).
  const std::string text = read_yaml_text(path, "detector parameters file");
  const ErrorContext ctx{.file = path.string()};
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error(std::string("cannot parse detector parameters: ") + e.what(), ctx);
  }
  if (!fs.isOpened()) throw Error("cannot open detector parameters", ctx);
  const cv::FileNode root = fs.root();
  for (const std::string& key : root.keys()) {
    if (in_list(key, kIgnoredKeys)) {
      spdlog::warn("{}: key '{}' is not used by this OpenCV version", path.string(), key);
      continue;
    }
    if (!in_list(key, kParameterKeys)) {
      throw Error("unknown detector parameter", {.file = path.string(), .field = key});
    }
    if (!root[key].isInt() && !root[key].isReal()) {
      throw Error("detector parameter must be a number", {.file = path.string(), .field = key});
    }
  }
  if (!parameters.readDetectorParameters(root)) {
    throw Error("cannot read detector parameters", ctx);
  }
}

}  // namespace

void read_detector_parameters(const std::filesystem::path& path,
                              cv::aruco::DetectorParameters& parameters) {
  return read_naming_file(path, "detector parameters file",
                          [&] { return read_parameters_text(path, parameters); });
}

MarkerDetector::MarkerDetector(DetectorOptions options) : options_(std::move(options)) {
  options_.check();
  dictionary_ = make_dictionary(options_.dictionary);
  parameters_ = cv::aruco::DetectorParameters::create();
  // Sub-pixel refinement is done here rather than by OpenCV, with a window scaled to the marker's
  // cell size: OpenCV 4.6 uses one fixed window, which on small markers (cells of 3-4 px) reaches
  // into the data bits and pulls the corners by several pixels.
  parameters_->cornerRefinementMethod = refinement_method(options_.corner_refinement);
  parameters_->cornerRefinementWinSize = options_.refinement_window;
  parameters_->cornerRefinementMaxIterations = options_.refinement_max_iterations;
  parameters_->cornerRefinementMinAccuracy = options_.refinement_min_accuracy;
  parameters_->minMarkerPerimeterRate = options_.min_marker_perimeter_rate;
  parameters_->minMarkerDistanceRate = options_.min_marker_distance_rate;
  parameters_->useAruco3Detection = options_.aruco3;
  if (!options_.parameters_file.empty()) {
    read_detector_parameters(options_.parameters_file, *parameters_);
  }
}

void MarkerDetector::refine_corners(const cv::Mat& grey,
                                    std::vector<std::vector<cv::Point2f>>& corners) const {
  const int cells = dictionary_->markerSize + 2 * parameters_->markerBorderBits;
  const cv::TermCriteria criteria(cv::TermCriteria::MAX_ITER | cv::TermCriteria::EPS,
                                  options_.refinement_max_iterations,
                                  options_.refinement_min_accuracy);
  for (auto& quad : corners) {
    if (quad.size() != 4) continue;
    double min_edge = 1e9;
    for (int c = 0; c < 4; ++c)
      min_edge = std::min(min_edge, static_cast<double>(cv::norm(quad[(c + 1) % 4] - quad[c])));
    const int half = std::clamp(static_cast<int>(std::lround(kWindowPerCell * min_edge / cells)), 1,
                                options_.refinement_window);
    cv::cornerSubPix(grey, quad, cv::Size(half, half), cv::Size(-1, -1), criteria);
    if (options_.corner_refinement == CornerRefinement::kEdgeLines) {
      std::array<cv::Point2f, 4> q{quad[0], quad[1], quad[2], quad[3]};
      if (refine_corners_by_edges(grey, q, cells)) quad.assign(q.begin(), q.end());
    }
  }
}

std::vector<MarkerObservation> MarkerDetector::detect(const cv::Mat& image) const {
  if (image.empty()) throw Error("marker detection: empty image", {.field = "image"});
  if (image.depth() != CV_8U) {
    throw Error("marker detection: want an 8-bit image", {.field = "image"});
  }
  cv::Mat grey;
  switch (image.channels()) {
    case 1:
      grey = image;
      break;
    case 3:
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
      break;
    default:
      throw Error("marker detection: want 1, 3 or 4 channels", {.field = "image"});
  }
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(grey, dictionary_, corners, ids, parameters_);

  if (options_.corner_refinement == CornerRefinement::kSubpixel ||
      options_.corner_refinement == CornerRefinement::kEdgeLines) {
    refine_corners(grey, corners);
  }

  std::vector<MarkerObservation> out;
  out.reserve(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (corners[i].size() != 4) continue;
    MarkerObservation obs;
    obs.id = ids[i];
    obs.image_width = grey.cols;
    obs.image_height = grey.rows;
    for (int c = 0; c < 4; ++c)
      obs.corners[c] = {corners[i][c].x, corners[i][c].y};
    out.push_back(obs);
  }
  remove_nested_duplicates(out);
  std::sort(out.begin(), out.end(), [](const MarkerObservation& a, const MarkerObservation& b) {
    if (a.id != b.id) return a.id < b.id;
    return a.centre().x() < b.centre().x();
  });
  return out;
}

cv::Mat draw_observations(const cv::Mat& image,
                          const std::vector<MarkerObservation>& observations) {
  cv::Mat out;
  if (image.channels() == 1) {
    cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, out, cv::COLOR_BGRA2BGR);
  } else {
    out = image.clone();
  }
  const int thickness = std::max(1, std::max(out.cols, out.rows) / 700);
  for (const MarkerObservation& obs : observations) {
    std::array<cv::Point, 4> pts;
    for (int c = 0; c < 4; ++c) {
      pts[c] = cv::Point(cvRound(obs.corners[c].x()), cvRound(obs.corners[c].y()));
    }
    for (int c = 0; c < 4; ++c) {
      cv::line(out, pts[c], pts[(c + 1) % 4], cv::Scalar(0, 255, 0), thickness, cv::LINE_AA);
    }
    cv::circle(out, pts[0], 3 * thickness, cv::Scalar(0, 0, 255), thickness, cv::LINE_AA);
    const Eigen::Vector2d c = obs.centre();
    cv::putText(out, std::to_string(obs.id), cv::Point(cvRound(c.x()), cvRound(c.y())),
                cv::FONT_HERSHEY_SIMPLEX, 0.6 * thickness, cv::Scalar(255, 0, 0), thickness,
                cv::LINE_AA);
  }
  return out;
}

}  // namespace coloc::markers
