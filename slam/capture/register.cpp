#include "slam/capture/register.hpp"

#include <cmath>

#include "slam/core/error.hpp"

namespace coloc::capture {

DepthRegistrar::DepthRegistrar(const PinholeCamera& depth, const PinholeCamera& color,
                               const SE3& color_from_depth)
    : depth_(depth), color_(color), color_distorted_(color.has_distortion()) {
  if (depth.has_distortion())
    throw Error("depth registration: the depth camera must be rectified (no distortion)");
  if (depth.width <= 0 || depth.height <= 0 || color.width <= 0 || color.height <= 0)
    throw Error("depth registration: camera with an empty image size");
  ray_x_.resize(static_cast<std::size_t>(depth.width));
  ray_y_.resize(static_cast<std::size_t>(depth.height));
  for (int x = 0; x < depth.width; ++x)
    ray_x_[x] = static_cast<float>((x - depth.cx) / depth.fx);
  for (int y = 0; y < depth.height; ++y)
    ray_y_[y] = static_cast<float>((y - depth.cy) / depth.fy);
  const Eigen::Matrix3d r = color_from_depth.rotation();
  for (int i = 0; i < 9; ++i)
    r_[i] = static_cast<float>(r(i / 3, i % 3));
  for (int i = 0; i < 3; ++i)
    t_[i] = static_cast<float>(color_from_depth.translation()[i]);
}

cv::Mat DepthRegistrar::register_raw(const cv::Mat& depth_raw, double units_per_metre) const {
  if (depth_raw.type() != CV_16UC1 || depth_raw.cols != depth_.width ||
      depth_raw.rows != depth_.height)
    throw Error("depth registration: expected a " + std::to_string(depth_.width) + "x" +
                std::to_string(depth_.height) + " 16-bit depth image");
  cv::Mat out(color_.height, color_.width, CV_16UC1, cv::Scalar(0));
  const float scale = static_cast<float>(1.0 / units_per_metre);
  const float units = static_cast<float>(units_per_metre);
  const auto fx = static_cast<float>(color_.fx), fy = static_cast<float>(color_.fy);
  const auto cx = static_cast<float>(color_.cx), cy = static_cast<float>(color_.cy);
  const auto& k = color_.distortion;
  const int w = color_.width, h = color_.height;
  for (int y = 0; y < depth_raw.rows; ++y) {
    const auto* row = depth_raw.ptr<std::uint16_t>(y);
    const float ry = ray_y_[y];
    // Rotation applied to the ray once per row: p = z * (ray_x * r_col0 + ry * r_col1 + r_col2).
    const float by0 = r_[1] * ry + r_[2], by1 = r_[4] * ry + r_[5], by2 = r_[7] * ry + r_[8];
    for (int x = 0; x < depth_raw.cols; ++x) {
      const std::uint16_t raw = row[x];
      if (raw == 0) continue;
      const float z = raw * scale, rx = ray_x_[x];
      const float px = z * (r_[0] * rx + by0) + t_[0];
      const float py = z * (r_[3] * rx + by1) + t_[1];
      const float pz = z * (r_[6] * rx + by2) + t_[2];
      if (pz <= 0.0f) continue;
      float u = px / pz, v = py / pz;
      if (color_distorted_) {
        const float r2 = u * u + v * v;
        const float radial =
            1.0f + r2 * (static_cast<float>(k[0]) +
                         r2 * (static_cast<float>(k[1]) + r2 * static_cast<float>(k[4])));
        const float du = 2.0f * static_cast<float>(k[2]) * u * v +
                         static_cast<float>(k[3]) * (r2 + 2.0f * u * u);
        const float dv = static_cast<float>(k[2]) * (r2 + 2.0f * v * v) +
                         2.0f * static_cast<float>(k[3]) * u * v;
        u = u * radial + du;
        v = v * radial + dv;
      }
      // Rounded to the nearest pixel centre; the +0.5 keeps truncation correct for >= 0 only.
      const float fu = fx * u + cx + 0.5f, fv = fy * v + cy + 0.5f;
      if (!(fu >= 0.0f && fv >= 0.0f)) continue;
      const int col = static_cast<int>(fu), row_out = static_cast<int>(fv);
      if (col >= w || row_out >= h) continue;
      auto& dst = out.at<std::uint16_t>(row_out, col);
      const auto value = static_cast<std::uint16_t>(std::min(65535.0f, pz * units + 0.5f));
      if (dst == 0 || value < dst) dst = value;
    }
  }
  return out;
}

}  // namespace coloc::capture
