#include "markers/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "markers/marker_pose.hpp"
#include "slam/core/error.hpp"

namespace coloc::markers {
namespace {

// Pixel bounding box of the marker and its quiet zone, clipped to the image; empty when the
// marker is behind the camera.
cv::Rect marker_bbox(const Camera& camera, const SE3& camera_from_marker, double half_extent,
                     int width, int height) {
  double x0 = std::numeric_limits<double>::max(), y0 = x0;
  double x1 = std::numeric_limits<double>::lowest(), y1 = x1;
  for (const Eigen::Vector3d& c : marker_corners(2.0 * half_extent)) {
    const Eigen::Vector3d p = camera_from_marker * c;
    if (!(p.z() > 1e-6)) return {};  // partly behind the camera: not rendered
    const Eigen::Vector2d u = project(camera, p);
    x0 = std::min(x0, u.x());
    y0 = std::min(y0, u.y());
    x1 = std::max(x1, u.x());
    y1 = std::max(y1, u.y());
  }
  // Distortion can bulge edges outwards: pad by a few pixels.
  const int pad = 4;
  const int ix0 = std::max(0, static_cast<int>(std::floor(x0)) - pad);
  const int iy0 = std::max(0, static_cast<int>(std::floor(y0)) - pad);
  const int ix1 = std::min(width - 1, static_cast<int>(std::ceil(x1)) + pad);
  const int iy1 = std::min(height - 1, static_cast<int>(std::ceil(y1)) + pad);
  if (ix1 < ix0 || iy1 < iy0) return {};
  return {ix0, iy0, ix1 - ix0 + 1, iy1 - iy0 + 1};
}

}  // namespace

void render_marker(cv::Mat& image, const Camera& camera, const SE3& camera_from_marker,
                   const cv::aruco::Dictionary& dictionary, int id, double marker_size,
                   const RenderOptions& options) {
  if (image.cols != image_width(camera) || image.rows != image_height(camera)) {
    throw Error("render_marker: image size differs from the camera's", {.field = "image"});
  }
  const int cells = dictionary.markerSize + 2;
  const double half_extent = 0.5 * marker_size + options.quiet_zone_cells * marker_size / cells;
  const cv::Rect box = marker_bbox(camera, camera_from_marker, half_extent, image.cols, image.rows);
  if (box.empty()) return;
  render_marker_rays(
      image, box, [&](const Eigen::Vector2d& pixel) { return unproject(camera, pixel); },
      camera_from_marker, dictionary, id, marker_size, options);
}

void render_marker_rays(cv::Mat& image, const cv::Rect& box, const BearingFunction& bearing,
                        const SE3& camera_from_marker, const cv::aruco::Dictionary& dictionary,
                        int id, double marker_size, const RenderOptions& options) {
  if (image.type() != CV_8UC1) {
    throw Error("render_marker: want an 8-bit grey image", {.field = "image"});
  }
  if (options.supersample < 1) throw Error("must be >= 1", {.field = "supersample"});
  const int cells = dictionary.markerSize + 2;  // data bits plus the one-cell black border
  cv::Mat bits;
  dictionary.drawMarker(id, cells, bits, 1);  // one pixel per cell
  const double cell = marker_size / cells;
  const double half = 0.5 * marker_size;
  const double half_extent = half + options.quiet_zone_cells * cell;
  const cv::Rect clipped = box & cv::Rect(0, 0, image.cols, image.rows);

  const SE3 marker_from_camera = camera_from_marker.inverse();
  const Eigen::Matrix3d r = marker_from_camera.rotation();
  const Eigen::Vector3d o = marker_from_camera.translation();
  const int n = options.supersample;
  for (int y = clipped.y; y < clipped.y + clipped.height; ++y) {
    unsigned char* row = image.ptr<unsigned char>(y);
    for (int x = clipped.x; x < clipped.x + clipped.width; ++x) {
      double sum = 0.0;
      int hits = 0;
      for (int sy = 0; sy < n; ++sy) {
        for (int sx = 0; sx < n; ++sx) {
          const Eigen::Vector2d pixel(x - 0.5 + (sx + 0.5) / n, y - 0.5 + (sy + 0.5) / n);
          const Eigen::Vector3d d = r * bearing(pixel);
          if (!d.allFinite() || std::abs(d.z()) < 1e-12) continue;
          const double t = -o.z() / d.z();
          if (!(t > 0.0)) continue;
          const Eigen::Vector3d p = o + t * d;
          if (std::abs(p.x()) > half_extent || std::abs(p.y()) > half_extent) continue;
          ++hits;
          if (std::abs(p.x()) >= half || std::abs(p.y()) >= half) {
            sum += options.white;  // quiet zone
            continue;
          }
          const int col = std::clamp(static_cast<int>((p.x() + half) / cell), 0, cells - 1);
          const int rw = std::clamp(static_cast<int>((half - p.y()) / cell), 0, cells - 1);
          sum += bits.at<unsigned char>(rw, col) > 127 ? options.white : options.black;
        }
      }
      if (hits == 0) continue;
      const double total = sum + static_cast<double>(n * n - hits) * row[x];
      row[x] = static_cast<unsigned char>(std::lround(total / (n * n)));
    }
  }
}

}  // namespace coloc::markers
