#include "registration/handeye/opencv/visp_franka.hpp"

#include <cmath>
#include <fstream>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::registration::handeye {

namespace {

std::string read_text(const std::filesystem::path& path) {
  check_input_file(path, "ViSP file");
  std::ifstream in(path);
  if (!in) throw Error("cannot open file", {.file = path.string()});
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// The number between <tag> and </tag> (ViSP's camera XML).
double xml_number(const std::string& text, const std::string& tag,
                  const std::filesystem::path& path) {
  const std::string open = "<" + tag + ">";
  const std::size_t begin = text.find(open);
  const std::size_t end = text.find("</" + tag + ">");
  if (begin == std::string::npos || end == std::string::npos || end < begin) {
    throw Error("missing element", {.file = path.string(), .field = tag});
  }
  try {
    return std::stod(text.substr(begin + open.size(), end - begin - open.size()));
  } catch (const std::exception&) {
    throw Error("not a number", {.file = path.string(), .field = tag});
  }
}

// ViSP's vpPoseVector YAML: "data:" followed by six "- [value]" lines: t (m) then theta-u (rad).
SE3 read_pose_vector(const std::filesystem::path& path) {
  check_input_file(path, "ViSP pose file");
  std::ifstream in(path);
  if (!in) throw Error("cannot open file", {.file = path.string()});
  std::string line;
  std::vector<double> values;
  bool in_data = false;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.rfind("data:", 0) == 0) {
      in_data = true;
      continue;
    }
    if (!in_data) continue;
    const std::size_t open = line.find('[');
    const std::size_t close = line.find(']');
    if (open == std::string::npos || close == std::string::npos) continue;
    try {
      values.push_back(std::stod(line.substr(open + 1, close - open - 1)));
    } catch (const std::exception&) {
      throw Error("not a number", {.file = path.string(), .field = "data", .line = line_number});
    }
  }
  if (values.size() != 6) {
    throw Error("expected 6 values [t; theta-u], got " + std::to_string(values.size()),
                {.file = path.string(), .field = "data"});
  }
  return SE3(SO3::exp(Eigen::Vector3d(values[3], values[4], values[5])),
             Eigen::Vector3d(values[0], values[1], values[2]));
}

double read_tag_size(const std::filesystem::path& path) {
  const std::string text = read_text(path);
  const std::size_t at = text.find("size:");
  if (at == std::string::npos)
    throw Error("missing tag size", {.file = path.string(), .field = "size"});
  try {
    return std::stod(text.substr(at + 5));
  } catch (const std::exception&) {
    throw Error("not a number", {.file = path.string(), .field = "size"});
  }
}

}  // namespace

FrankaSession load_visp_franka_eye_to_hand(const std::filesystem::path& directory) {
  const std::filesystem::path camera_path = directory / "franka_camera.xml";
  const std::string camera_xml = read_text(camera_path);
  cv::Matx33d k = cv::Matx33d::eye();
  k(0, 0) = xml_number(camera_xml, "px", camera_path);
  k(1, 1) = xml_number(camera_xml, "py", camera_path);
  k(0, 2) = xml_number(camera_xml, "u0", camera_path);
  k(1, 2) = xml_number(camera_xml, "v0", camera_path);

  FrankaSession session;
  session.tag_size = read_tag_size(directory / "apriltag-data.txt");
  const double h = 0.5 * session.tag_size;
  // ArUco corner order (top-left, top-right, bottom-right, bottom-left) in the tag frame
  // (x right, y up, z out of the tag towards the camera).
  const std::vector<cv::Point3d> object = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(cv::aruco::DICT_APRILTAG_36h11);
  const cv::Ptr<cv::aruco::DetectorParameters> parameters = cv::aruco::DetectorParameters::create();
  parameters->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;

  for (int n = 1;; ++n) {
    const std::string image_name = "franka_image-" + std::to_string(n) + ".png";
    const std::filesystem::path pose_path =
        directory / ("franka_pose_rPe_" + std::to_string(n) + ".yaml");
    if (!std::filesystem::exists(directory / image_name) || !std::filesystem::exists(pose_path)) {
      break;
    }
    ++session.num_images;
    const cv::Mat image = cv::imread((directory / image_name).string(), cv::IMREAD_GRAYSCALE);
    if (image.empty())
      throw Error("cannot read image", {.file = (directory / image_name).string()});
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(image, dictionary, corners, ids, parameters);
    if (ids.size() != 1) continue;  // no tag, or ambiguous
    cv::Vec3d rvec, tvec;
    std::vector<cv::Point2d> pixels(corners[0].begin(), corners[0].end());
    cv::solvePnP(object, pixels, k, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE);
    std::vector<cv::Point2d> projected;
    cv::projectPoints(object, rvec, tvec, k, cv::noArray(), projected);
    double squared = 0.0;
    for (std::size_t c = 0; c < 4; ++c) {
      const cv::Point2d d = projected[c] - pixels[c];
      squared += d.dot(d);
    }
    const SE3 camera_from_tag(SO3::exp(Eigen::Vector3d(rvec[0], rvec[1], rvec[2])),
                              Eigen::Vector3d(tvec[0], tvec[1], tvec[2]));
    session.registrations.push_back({read_pose_vector(pose_path), camera_from_tag});
    session.images.push_back(image_name);
    session.reprojection_rms_px.push_back(std::sqrt(squared / 4.0));
  }
  if (session.num_images == 0) {
    throw Error("no franka_image-N.png / franka_pose_rPe_N.yaml pairs found",
                {.file = directory.string()});
  }
  return session;
}

}  // namespace coloc::registration::handeye
