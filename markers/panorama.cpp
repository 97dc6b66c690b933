#include "markers/panorama.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "markers/marker_pose.hpp"
#include "slam/core/error.hpp"

namespace coloc::markers {
namespace {

constexpr int kPad = 2;  // columns/rows added around the panorama before remapping

}  // namespace

PanoramaModel PanoramaModel::equirectangular(int width) {
  PanoramaModel m;
  m.width = width;
  m.height = width / 2;
  m.pixel_width = 2.0 * M_PI / width;
  m.pixel_height = M_PI / m.height;
  return m;
}

void PanoramaModel::check() const {
  if (width <= 0 || height <= 0) throw Error("panorama size must be positive", {.field = "width"});
  if (!(pixel_width > 0.0)) throw Error("must be positive", {.field = "pixelWidth"});
  if (!(pixel_height > 0.0)) throw Error("must be positive", {.field = "pixelHeight"});
  if (kind == PanoramaKind::kCylindrical && !(radius > 0.0)) {
    throw Error("must be positive", {.field = "radius"});
  }
}

Eigen::Vector3d PanoramaModel::direction(const Eigen::Vector2d& pixel) const {
  const double theta = M_PI - (pixel.x() + 0.5) * pixel_width;
  double phi = 0.0;
  if (kind == PanoramaKind::kSpherical) {
    phi = (0.5 * height - pixel.y() - 0.5) * pixel_height;
    if (std::abs(phi) > 0.5 * M_PI) return Eigen::Vector3d::Constant(std::nan(""));
  } else {
    phi = std::atan2((principal_point_y - pixel.y()) * pixel_height, radius);
  }
  return {std::cos(phi) * std::cos(theta), std::cos(phi) * std::sin(theta), std::sin(phi)};
}

Eigen::Vector2d PanoramaModel::pixel(const Eigen::Vector3d& d) const {
  const double theta = std::atan2(d.y(), d.x());
  const double rho = std::hypot(d.x(), d.y());
  double column = (M_PI - theta) / pixel_width - 0.5;
  if (column >= width - 0.5) column -= 2.0 * M_PI / pixel_width;
  double row = 0.0;
  if (kind == PanoramaKind::kSpherical) {
    row = 0.5 * height - std::atan2(d.z(), rho) / pixel_height - 0.5;
  } else {
    row = principal_point_y - radius * d.z() / rho / pixel_height;
  }
  return {column, row};
}

cv::Mat resample_cube_face(const cv::Mat& panorama, const PanoramaModel& model, int face,
                           int size) {
  model.check();
  if (panorama.cols != model.width || panorama.rows != model.height) {
    throw Error("panorama size " + std::to_string(panorama.cols) + "x" +
                    std::to_string(panorama.rows) + " differs from its model's " +
                    std::to_string(model.width) + "x" + std::to_string(model.height),
                {.field = "image"});
  }
  if (size < 8) throw Error("cube face size must be >= 8", {.field = "cube_face_size"});
  // Wrap the azimuth seam, replicate the poles, so bilinear lookups near the edges are defined.
  cv::Mat wrapped, padded;
  cv::copyMakeBorder(panorama, wrapped, 0, 0, kPad, kPad, cv::BORDER_WRAP);
  cv::copyMakeBorder(wrapped, padded, kPad, kPad, 0, 0, cv::BORDER_REPLICATE);

  const PinholeCamera camera = cube_face_camera(size);
  const Eigen::Matrix3d panorama_from_face = cube_face_rotations().at(face).matrix();
  cv::Mat map_x(size, size, CV_32FC1), map_y(size, size, CV_32FC1);
  for (int v = 0; v < size; ++v) {
    float* mx = map_x.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    for (int u = 0; u < size; ++u) {
      const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const Eigen::Vector2d p = model.pixel(panorama_from_face * ray);
      mx[u] = static_cast<float>(p.x() + kPad);
      my[u] = static_cast<float>(p.y() + kPad);
    }
  }
  cv::Mat out;
  cv::remap(padded, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

void render_marker_panorama(cv::Mat& panorama, const PanoramaModel& model,
                            const SE3& panorama_from_marker,
                            const cv::aruco::Dictionary& dictionary, int id, double marker_size,
                            const RenderOptions& options) {
  model.check();
  const int cells = dictionary.markerSize + 2;
  const double half = 0.5 * marker_size + options.quiet_zone_cells * marker_size / cells;
  // Bounding box from points along the outline (edges of a panorama's image are curves).
  double x0 = std::numeric_limits<double>::max(), y0 = x0;
  double x1 = std::numeric_limits<double>::lowest(), y1 = x1;
  const auto corners = marker_corners(2.0 * half);
  constexpr int kSteps = 32;
  for (int c = 0; c < 4; ++c) {
    for (int s = 0; s < kSteps; ++s) {
      const Eigen::Vector3d p =
          corners[c] + (corners[(c + 1) % 4] - corners[c]) * (static_cast<double>(s) / kSteps);
      const Eigen::Vector2d u = model.pixel(panorama_from_marker * p);
      x0 = std::min(x0, u.x());
      y0 = std::min(y0, u.y());
      x1 = std::max(x1, u.x());
      y1 = std::max(y1, u.y());
    }
  }
  if (x1 - x0 > 0.5 * model.width) {  // straddles the seam
    x0 = 0;
    x1 = model.width - 1;
  }
  const int pad = 3;
  const cv::Rect box(
      cv::Point(static_cast<int>(std::floor(x0)) - pad, static_cast<int>(std::floor(y0)) - pad),
      cv::Point(static_cast<int>(std::ceil(x1)) + pad + 1,
                static_cast<int>(std::ceil(y1)) + pad + 1));
  render_marker_rays(
      panorama, box, [&](const Eigen::Vector2d& pixel) { return model.direction(pixel); },
      panorama_from_marker, dictionary, id, marker_size, options);
}

}  // namespace coloc::markers
