#include "slam/frame/frame.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "slam/core/error.hpp"
#include "slam/frame/rolling_shutter.hpp"

namespace coloc::slam::frame {

FrameGeometry FrameGeometry::make(const Camera& camera, double bf, double close_depth,
                                  const std::vector<float>& scale_factors) {
  FrameGeometry g;
  const Eigen::Matrix3d k = intrinsic_matrix(camera);
  g.fx = k(0, 0);
  g.fy = k(1, 1);
  g.cx = k(0, 2);
  g.cy = k(1, 2);
  g.bf = bf;
  g.close_depth = close_depth;
  const double w = image_width(camera), h = image_height(camera);
  // Bounds of the undistorted image: the undistorted corners (ORB-SLAM's ComputeImageBounds).
  g.min_x = 0.0;
  g.max_x = w;
  g.min_y = 0.0;
  g.max_y = h;
  if (w > 0 && h > 0) {
    const Eigen::Vector2d corners[4] = {{0, 0}, {w - 1, 0}, {0, h - 1}, {w - 1, h - 1}};
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (const auto& c : corners) {
      const Eigen::Vector2d u = undistort_pixel(camera, c);
      if (!std::isfinite(u.x()) || !std::isfinite(u.y())) continue;
      x0 = std::min(x0, u.x());
      x1 = std::max(x1, u.x());
      y0 = std::min(y0, u.y());
      y1 = std::max(y1, u.y());
    }
    if (x1 > x0 && y1 > y0) {
      g.min_x = std::min(0.0, x0);
      g.max_x = std::max(w, x1);
      g.min_y = std::min(0.0, y0);
      g.max_y = std::max(h, y1);
    }
  }
  g.scale_factors = scale_factors;
  for (float s : scale_factors)
    g.level_sigma2.push_back(s * s);
  if (scale_factors.size() > 1) g.log_scale_factor = std::log(scale_factors[1]);
  return g;
}

void FrameGeometry::check() const {
  if (!(fx > 0.0) || !(fy > 0.0)) throw Error("FrameGeometry: fx, fy must be positive");
  if (!(bf > 0.0)) throw Error("FrameGeometry: bf must be positive (RGB-D needs Camera.bf)");
  if (!(close_depth > 0.0)) throw Error("FrameGeometry: close_depth must be positive");
  if (!(max_x > min_x) || !(max_y > min_y)) throw Error("FrameGeometry: empty image bounds");
  if (grid_cols < 1 || grid_rows < 1) throw Error("FrameGeometry: grid_cols/grid_rows < 1");
  if (scale_factors.empty()) throw Error("FrameGeometry: scale_factors empty");
}

Frame::Frame(FrameId frame_id, double stamp, features::OrbFeatures feats,
             const cv::Mat& depth_image, std::shared_ptr<const FrameGeometry> geometry)
    : id(frame_id), timestamp(stamp), features(std::move(feats)), geometry_(std::move(geometry)) {
  const std::size_t n = features.size();
  depth.assign(n, -1.0f);
  u_right.assign(n, -1.0f);
  points.assign(n, MapPointId::invalid());
  outlier.assign(n, 0);
  const FrameGeometry& g = *geometry_;
  if (!depth_image.empty()) {
    if (depth_image.type() != CV_32FC1) throw Error("Frame: depth image must be CV_32FC1 metres");
    for (std::size_t i = 0; i < n; ++i) {
      // Depth is registered to the distorted colour image: look it up at the detected pixel.
      const auto& kp = features.keypoints[i];
      const int u = static_cast<int>(std::lround(kp.x));
      const int v = static_cast<int>(std::lround(kp.y));
      if (u < 0 || v < 0 || u >= depth_image.cols || v >= depth_image.rows) continue;
      const float d = depth_image.at<float>(v, u);
      if (!(d >= g.min_depth && d <= g.max_depth)) continue;
      depth[i] = d;
      u_right[i] = static_cast<float>(kp.ux - g.bf / d);
    }
  }
  assign_grid();
}

Frame::Frame(FrameId frame_id, double stamp, features::OrbFeatures feats, std::vector<float> depths,
             std::vector<float> u_rights, std::shared_ptr<const FrameGeometry> geometry)
    : id(frame_id),
      timestamp(stamp),
      features(std::move(feats)),
      depth(std::move(depths)),
      u_right(std::move(u_rights)),
      geometry_(std::move(geometry)) {
  const std::size_t n = features.size();
  if (!geometry_) throw Error("Frame: no geometry");
  if (features.descriptors.size() != n || depth.size() != n || u_right.size() != n)
    throw Error("Frame: keypoints, descriptors, depth and u_right differ in count");
  points.assign(n, MapPointId::invalid());
  outlier.assign(n, 0);
  assign_grid();
}

void Frame::assign_grid() {
  const FrameGeometry& g = *geometry_;
  const auto cells = static_cast<std::size_t>(g.grid_cols) * static_cast<std::size_t>(g.grid_rows);
  const double sx = g.grid_cols / (g.max_x - g.min_x), sy = g.grid_rows / (g.max_y - g.min_y);
  // The cell of keypoint i, or `cells` outside the bounds.
  const auto cell_of = [&](std::size_t i) {
    const auto& kp = features.keypoints[i];
    const int c = static_cast<int>(std::floor((kp.ux - g.min_x) * sx));
    const int r = static_cast<int>(std::floor((kp.uy - g.min_y) * sy));
    if (c < 0 || r < 0 || c >= g.grid_cols || r >= g.grid_rows) return cells;
    return static_cast<std::size_t>(r * g.grid_cols + c);
  };
  // Counting sort by cell, stable: each cell lists its keypoints in ascending order.
  grid_start_.assign(cells + 1, 0);
  for (std::size_t i = 0; i < features.size(); ++i)
    if (const std::size_t cell = cell_of(i); cell < cells) ++grid_start_[cell + 1];
  for (std::size_t cell = 1; cell <= cells; ++cell)
    grid_start_[cell] += grid_start_[cell - 1];
  grid_keypoint_.assign(grid_start_[cells], 0);
  // grid_start_[cell] serves as the cell's write cursor, which ends at the next cell's start...
  for (std::size_t i = 0; i < features.size(); ++i)
    if (const std::size_t cell = cell_of(i); cell < cells)
      grid_keypoint_[grid_start_[cell]++] = static_cast<std::uint32_t>(i);
  // ...so shifting the cursors by one cell restores the starts.
  for (std::size_t cell = cells; cell > 0; --cell)
    grid_start_[cell] = grid_start_[cell - 1];
  grid_start_[0] = 0;
}

Eigen::Vector3d Frame::unproject_world(std::size_t i) const {
  const FrameGeometry& g = *geometry_;
  const double z = depth[i];
  const Eigen::Vector3d p((features.keypoints[i].ux - g.cx) * z / g.fx,
                          (features.keypoints[i].uy - g.cy) * z / g.fy, z);
  return cam_from_world.inverse() * p;
}

void Frame::drop_search_data() {
  // Swapped with empty vectors: `v = {}` would assign an empty list and keep the capacity.
  std::vector<float>().swap(depth);
  std::vector<float>().swap(u_right);
  std::vector<std::uint32_t>().swap(grid_start_);
  std::vector<std::uint32_t>().swap(grid_keypoint_);
}

std::vector<std::size_t> Frame::features_in_area(double x, double y, double radius, int min_level,
                                                 int max_level) const {
  std::vector<std::size_t> out;
  if (grid_start_.empty()) return out;  // drop_search_data()
  const FrameGeometry& g = *geometry_;
  const double sx = g.grid_cols / (g.max_x - g.min_x), sy = g.grid_rows / (g.max_y - g.min_y);
  const int c0 = std::max(0, static_cast<int>(std::floor((x - radius - g.min_x) * sx)));
  const int c1 =
      std::min(g.grid_cols - 1, static_cast<int>(std::floor((x + radius - g.min_x) * sx)));
  const int r0 = std::max(0, static_cast<int>(std::floor((y - radius - g.min_y) * sy)));
  const int r1 =
      std::min(g.grid_rows - 1, static_cast<int>(std::floor((y + radius - g.min_y) * sy)));
  if (c0 > c1 || r0 > r1) return out;
  const double r2 = radius * radius;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      const auto cell = static_cast<std::size_t>(r * g.grid_cols + c);
      for (std::uint32_t k = grid_start_[cell]; k < grid_start_[cell + 1]; ++k) {
        const std::uint32_t i = grid_keypoint_[k];
        const auto& kp = features.keypoints[i];
        if (kp.level < min_level || (max_level >= 0 && kp.level > max_level)) continue;
        const double dx = kp.ux - x, dy = kp.uy - y;
        if (dx * dx + dy * dy <= r2) out.push_back(i);
      }
    }
  }
  return out;
}

void Frame::compensate_rolling_shutter(const Eigen::Vector3d& omega_cam, int image_rows,
                                       double readout) {
  shutter_rate = omega_cam;
  shutter_rows = image_rows;
  shutter_readout = readout;
  compensate(omega_cam, readout);
}

void Frame::set_shutter_readout(double readout) {
  if (shutter_rate.isZero() || shutter_rows <= 0 || readout == shutter_readout) return;
  // Both compensations turn each bearing about the same axis: the difference is one more turn.
  compensate(shutter_rate, readout - shutter_readout);
  shutter_readout = readout;
}

void Frame::set_shutter_rate(const Eigen::Vector3d& omega_cam) {
  if (shutter_rows <= 0) return;
  compensate(shutter_rate, -shutter_readout);  // undone exactly: each row keeps its time
  shutter_rate = omega_cam;
  compensate(omega_cam, shutter_readout);
}

Eigen::Vector3d Frame::shutter_shear(std::size_t i) const {
  if (shutter_rows <= 0) return Eigen::Vector3d::Zero();
  return shutter_rate * row_time(features.keypoints[i].y, {1.0, shutter_rows});
}

void Frame::compensate(const Eigen::Vector3d& omega_cam, double readout) {
  if (readout == 0.0 || shutter_rows <= 0) return;
  const FrameGeometry& g = *geometry_;
  frame::compensate_rolling_shutter(features, {readout, shutter_rows}, omega_cam, g.fx, g.fy, g.cx,
                                    g.cy);
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (depth[i] > 0.0f)
      u_right[i] = static_cast<float>(features.keypoints[i].ux - g.bf / depth[i]);
  }
  assign_grid();
}

std::size_t Frame::tracked_count() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
    n += (points[i].valid() && !outlier[i]) ? 1 : 0;
  return n;
}

}  // namespace coloc::slam::frame
