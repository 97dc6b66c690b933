#include "registration/render/distortion_warp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "slam/core/error.hpp"

namespace coloc::registration::render {
namespace {

bool same_camera(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

}  // namespace

PinholeCamera DistortionWarp::prepare(const PinholeCamera& camera) {
  if (valid_ && same_camera(camera, camera_)) return ideal_;
  // Extent of the undistorted rays through the image border (pixel edges at -0.5, size - 0.5).
  double xmin = std::numeric_limits<double>::max(), xmax = -xmin, ymin = xmin, ymax = -xmin;
  const auto include = [&](double u, double v) {
    const Eigen::Vector2d xy =
        camera.undistort({(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy});
    xmin = std::min(xmin, xy.x());
    xmax = std::max(xmax, xy.x());
    ymin = std::min(ymin, xy.y());
    ymax = std::max(ymax, xy.y());
  };
  for (int u = 0; u <= camera.width; ++u) {
    include(u - 0.5, -0.5);
    include(u - 0.5, camera.height - 0.5);
  }
  for (int v = 0; v <= camera.height; ++v) {
    include(-0.5, v - 0.5);
    include(camera.width - 0.5, v - 0.5);
  }
  PinholeCamera ideal;
  ideal.fx = camera.fx;
  ideal.fy = camera.fy;
  ideal.cx = std::ceil(-xmin * camera.fx) + 2.0;
  ideal.cy = std::ceil(-ymin * camera.fy) + 2.0;
  ideal.width = static_cast<int>(std::ceil(ideal.cx + xmax * camera.fx)) + 3;
  ideal.height = static_cast<int>(std::ceil(ideal.cy + ymax * camera.fy)) + 3;
  if (ideal.width > 4 * camera.width || ideal.height > 4 * camera.height) {
    throw Error("render: distortion too strong for the post-warp (undistorted field too wide)",
                {.field = "distortion"});
  }
  map_x_.create(camera.height, camera.width, CV_32F);
  map_y_.create(camera.height, camera.width, CV_32F);
  nearest_.assign(static_cast<std::size_t>(camera.width) * camera.height, -1);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector2d xy =
          camera.undistort({(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy});
      const double iu = ideal.fx * xy.x() + ideal.cx;
      const double iv = ideal.fy * xy.y() + ideal.cy;
      map_x_.at<float>(v, u) = static_cast<float>(iu);
      map_y_.at<float>(v, u) = static_cast<float>(iv);
      const int nu = static_cast<int>(std::lround(iu));
      const int nv = static_cast<int>(std::lround(iv));
      if (nu >= 0 && nv >= 0 && nu < ideal.width && nv < ideal.height) {
        nearest_[static_cast<std::size_t>(v) * camera.width + u] = nv * ideal.width + nu;
      }
    }
  }
  camera_ = camera;
  ideal_ = ideal;
  valid_ = true;
  return ideal_;
}

bool DistortionWarp::interpolate(const RenderResult& ideal, int u, int v, float& depth,
                                 cv::Vec3f& point) const {
  // Inverse depth is affine in the image over a plane, so perspective-correct bilinear
  // interpolation is exact there. Nearest sampling instead puts the depth of a ray up to half a
  // pixel away on the pixel: on a wall seen at a grazing angle that is centimetres, the same
  // for every frame at that pixel, and SLAM on the twin inherited it as a bent map.
  const float iu = map_x_.at<float>(v, u);
  const float iv = map_y_.at<float>(v, u);
  const int i0 = static_cast<int>(std::floor(iu));
  const int j0 = static_cast<int>(std::floor(iv));
  if (i0 < 0 || j0 < 0 || i0 + 1 >= ideal_.width || j0 + 1 >= ideal_.height) return false;
  const float a = iu - static_cast<float>(i0);
  const float b = iv - static_cast<float>(j0);
  const float w[4] = {(1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b};
  const int di[4] = {0, 1, 0, 1};
  const int dj[4] = {0, 0, 1, 1};
  float inv[4];
  for (int k = 0; k < 4; ++k) {
    const float z = ideal.depth.at<float>(j0 + dj[k], i0 + di[k]);
    if (!(z > 0.0f)) return false;
    inv[k] = 1.0f / z;
  }
  // Four samples on one plane have zero cross difference of inverse depth; across an edge
  // they do not, and the nearest sample is the honest answer there.
  const float mean_inv = 0.25f * (inv[0] + inv[1] + inv[2] + inv[3]);
  if (std::abs(inv[0] + inv[3] - inv[1] - inv[2]) > kPlanarTolerance * mean_inv) return false;
  float inv_z = 0.0f;
  cv::Vec3f p(0.0f, 0.0f, 0.0f);
  for (int k = 0; k < 4; ++k) {
    inv_z += w[k] * inv[k];
    p += (w[k] * inv[k]) * ideal.points.at<cv::Vec3f>(j0 + dj[k], i0 + di[k]);
  }
  depth = 1.0f / inv_z;
  point = p * depth;
  return true;
}

RenderResult DistortionWarp::apply(const RenderResult& ideal) const {
  RenderResult r;
  cv::remap(ideal.colour, r.colour, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  const int w = camera_.width;
  const int h = camera_.height;
  r.depth = cv::Mat(h, w, CV_32F, cv::Scalar(0.0f));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  r.points = cv::Mat(h, w, CV_32FC3, cv::Scalar(nan, nan, nan));
  r.index = cv::Mat(h, w, CV_32S, cv::Scalar(-1));
  const auto* depth = ideal.depth.ptr<float>();
  const auto* points = ideal.points.ptr<cv::Vec3f>();
  const auto* index = ideal.index.ptr<int>();
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int k = nearest_[static_cast<std::size_t>(v) * w + u];
      if (k < 0) continue;
      r.index.at<int>(v, u) = index[k];
      // Splats (index >= 0) are discs, not surfaces: only their own centre point is honest.
      if (index[k] < 0 &&
          interpolate(ideal, u, v, r.depth.at<float>(v, u), r.points.at<cv::Vec3f>(v, u))) {
        continue;
      }
      r.depth.at<float>(v, u) = depth[k];
      r.points.at<cv::Vec3f>(v, u) = points[k];
    }
  }
  return r;
}

}  // namespace coloc::registration::render
