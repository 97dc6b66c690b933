#include "slam/capture/calibrate.hpp"

#include <cmath>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

struct Detection {
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;  // ChArUco corner ids
  std::vector<cv::Point3f> object;
};

cv::Ptr<cv::aruco::Dictionary> dictionary_by_name(const std::string& name) {
  static const std::pair<const char*, int> kNames[] = {
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
      {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
      {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
      {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL}};
  for (const auto& [n, id] : kNames)
    if (name == n) return cv::aruco::getPredefinedDictionary(id);
  throw Error("unknown dictionary '" + name + "'", {.field = "dictionary"});
}

std::optional<Detection> detect_chessboard(const cv::Mat& grey, const CalibrateOptions& o) {
  Detection d;
  const cv::Size size(o.cols, o.rows);
  if (!cv::findChessboardCorners(grey, size, d.corners,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return std::nullopt;
  cv::cornerSubPix(grey, d.corners, {5, 5}, {-1, -1},
                   {cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3});
  for (int r = 0; r < o.rows; ++r)
    for (int c = 0; c < o.cols; ++c)
      d.object.emplace_back(static_cast<float>(c * o.square), static_cast<float>(r * o.square),
                            0.0f);
  return d;
}

std::optional<Detection> detect_charuco(const cv::Mat& grey,
                                        const cv::Ptr<cv::aruco::CharucoBoard>& board) {
  std::vector<std::vector<cv::Point2f>> markers;
  std::vector<int> ids;
  cv::aruco::detectMarkers(grey, board->dictionary, markers, ids);
  if (ids.size() < 4) return std::nullopt;
  Detection d;
  cv::aruco::interpolateCornersCharuco(markers, ids, grey, board, d.corners, d.ids);
  if (d.ids.size() < 6) return std::nullopt;
  for (int id : d.ids)
    d.object.push_back(board->chessboardCorners[static_cast<std::size_t>(id)]);
  return d;
}

// Later images seen from (nearly) the pose of an earlier one are marked as adding nothing.
void mark_same_views(const std::vector<cv::Mat>& rvecs, const std::vector<cv::Mat>& tvecs,
                     const std::vector<std::size_t>& image_of, const CalibrateOptions& o,
                     std::vector<ImageReport>& reports) {
  for (std::size_t j = 1; j < rvecs.size(); ++j) {
    for (std::size_t i = 0; i < j; ++i) {
      cv::Mat ri, rj;
      cv::Rodrigues(rvecs[i], ri);
      cv::Rodrigues(rvecs[j], rj);
      cv::Mat rel_vec;
      cv::Rodrigues(ri.t() * rj, rel_vec);
      const double angle = cv::norm(rel_vec) * 180.0 / CV_PI;
      const double dist = cv::norm(tvecs[i] - tvecs[j]) / std::max(1e-9, cv::norm(tvecs[i]));
      if (angle < o.same_view_deg && dist < o.same_view_rel) {
        reports[image_of[j]].note =
            "adds nothing: the same view as " + reports[image_of[i]].path.filename().string();
        break;
      }
    }
  }
}

}  // namespace

void CalibrateOptions::check() const {
  if (cols < 2 || rows < 2) throw Error("board needs at least 2x2", {.field = "board size"});
  if (square <= 0) throw Error("must be positive", {.field = "--square"});
  if (target == Target::kCharuco && (marker <= 0 || marker >= square))
    throw Error("must be positive and smaller than the square", {.field = "--marker"});
}

std::size_t CameraCalibration::used() const {
  std::size_t n = 0;
  for (const auto& i : images)
    n += i.used ? 1 : 0;
  return n;
}

CameraCalibration calibrate_camera(const std::vector<fs::path>& paths, const CalibrateOptions& o) {
  o.check();
  cv::Ptr<cv::aruco::CharucoBoard> board;
  if (o.target == CalibrateOptions::Target::kCharuco)
    board = cv::aruco::CharucoBoard::create(o.cols, o.rows, static_cast<float>(o.square),
                                            static_cast<float>(o.marker),
                                            dictionary_by_name(o.dictionary));
  CameraCalibration result;
  std::vector<std::vector<cv::Point2f>> image_points;
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::size_t> image_of;
  cv::Size size;
  for (const fs::path& p : paths) {
    check_input_file(p, "calibration image");  // imread blocks forever on a FIFO
    const cv::Mat grey = cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
    if (grey.empty()) throw Error("cannot read image", {.file = p.string()});
    if (size.area() > 0 && grey.size() != size)
      throw Error("image size " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
                      " differs from the first image's",
                  {.file = p.string()});
    size = grey.size();
    ImageReport report{.path = p};
    const auto d = board ? detect_charuco(grey, board) : detect_chessboard(grey, o);
    if (!d) {
      report.note = board ? "no ChArUco board found (fewer than 6 corners)" : "no chessboard found";
    } else {
      report.corners = d->corners.size();
      image_points.push_back(d->corners);
      object_points.push_back(d->object);
      image_of.push_back(result.images.size());
    }
    result.images.push_back(std::move(report));
  }
  if (image_points.size() < 3) {
    std::string why;
    for (const auto& r : result.images)
      why += "\n  " + r.path.string() + ": " + (r.note.empty() ? "board found" : r.note);
    throw Error("the board was found in " + std::to_string(image_points.size()) +
                " images; calibration needs at least 3" + why);
  }
  cv::Mat k, dist, std_in, std_ex, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  result.rms_px = cv::calibrateCamera(object_points, image_points, size, k, dist, rvecs, tvecs,
                                      std_in, std_ex, per_view);
  for (std::size_t v = 0; v < image_of.size(); ++v) {
    ImageReport& r = result.images[image_of[v]];
    r.used = true;
    r.rms_px = per_view.at<double>(static_cast<int>(v));
  }
  mark_same_views(rvecs, tvecs, image_of, o, result.images);
  PinholeCamera& c = result.camera;
  c.width = size.width;
  c.height = size.height;
  c.fx = k.at<double>(0, 0);
  c.fy = k.at<double>(1, 1);
  c.cx = k.at<double>(0, 2);
  c.cy = k.at<double>(1, 2);
  for (int i = 0; i < 5 && i < static_cast<int>(dist.total()); ++i)
    c.distortion[static_cast<std::size_t>(i)] = dist.at<double>(i);
  return result;
}

}  // namespace coloc::capture
