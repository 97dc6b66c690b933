#include "slam/capture/register.hpp"

#include <cmath>

#include "slam/core/error.hpp"

namespace coloc::capture {

DepthRegistrar::DepthRegistrar(const PinholeCamera& depth, const PinholeCamera& color,
                               const SE3& color_from_depth)
    : depth_(depth), color_(color) {
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
  // One spare row: pixels that land nowhere are written to its first element, so the scatter
  // below needs no branch.
  cv::Mat out(color_.height + 1, color_.width, CV_16UC1, cv::Scalar(0));
  const auto n = static_cast<std::size_t>(depth_raw.cols);
  std::vector<std::int32_t> target(n);
  std::vector<std::uint16_t> value(n);
  auto* dst = out.ptr<std::uint16_t>();
  for (int y = 0; y < depth_raw.rows; ++y) {
    project_row(depth_raw.ptr<std::uint16_t>(y), y, static_cast<float>(units_per_metre),
                target.data(), value.data());
    // Nearest wins: with 0 (empty) wrapping to 65535, min(d - 1, v - 1) + 1 keeps the nearer.
    for (std::size_t x = 0; x < n; ++x) {
      std::uint16_t& d = dst[target[x]];
      d = static_cast<std::uint16_t>(
          std::min<std::uint16_t>(static_cast<std::uint16_t>(d - 1),
                                  static_cast<std::uint16_t>(value[x] - 1)) +
          1);
    }
  }
  return out.rowRange(0, color_.height);
}

// Branch-free so that the compiler runs it in SIMD lanes: each depth pixel's target index in
// the colour image (the spare row: no depth, behind the camera or outside) and its depth there
// (at least 1 unit: 0 means empty). Compiled twice, for x86-64 and for x86-64-v3 (AVX2 + FMA:
// 8 lanes), the loader picking the one the CPU runs. Not "arch=haswell": GCC dispatches that on
// the CPU model, so an AMD or a newer Intel CPU with AVX2 ran the 4-lane default clone.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void DepthRegistrar::project_row(const std::uint16_t* raw, int y, float units,
                                 std::int32_t* target, std::uint16_t* value) const {
  const float scale = 1.0f / units;
  const float ry = ray_y_[static_cast<std::size_t>(y)];
  // Rotation applied to the ray: p = z * (ray_x * r_col0 + ry * r_col1 + r_col2) + t.
  const float by0 = r_[1] * ry + r_[2], by1 = r_[4] * ry + r_[5], by2 = r_[7] * ry + r_[8];
  const float fx = static_cast<float>(color_.fx), fy = static_cast<float>(color_.fy);
  const float cx = static_cast<float>(color_.cx) + 0.5f, cy = static_cast<float>(color_.cy) + 0.5f;
  const float k1 = static_cast<float>(color_.distortion[0]),
              k2 = static_cast<float>(color_.distortion[1]);
  const float p1 = static_cast<float>(color_.distortion[2]),
              p2 = static_cast<float>(color_.distortion[3]);
  const float k3 = static_cast<float>(color_.distortion[4]);
  const float w = static_cast<float>(color_.width), h = static_cast<float>(color_.height);
  const int width = depth_.width, color_width = color_.width;
  const int spare = color_.height * color_.width;  // first element of the spare row
  const float* ray_x = ray_x_.data();
  const float r0 = r_[0], r3 = r_[3], r6 = r_[6], t0 = t_[0], t1 = t_[1], t2 = t_[2];
  for (int x = 0; x < width; ++x) {
    const float z = static_cast<float>(raw[x]) * scale, rx = ray_x[x];
    const float px = z * (r0 * rx + by0) + t0;
    const float py = z * (r3 * rx + by1) + t1;
    const float pz = z * (r6 * rx + by2) + t2;
    const float inv = 1.0f / std::max(pz, 1e-6f);
    const float u = px * inv, v = py * inv;
    // Brown-Conrady; with zero coefficients it leaves (u, v) as they are.
    const float r2 = u * u + v * v;
    const float radial = 1.0f + r2 * (k1 + r2 * (k2 + r2 * k3));
    const float ud = u * radial + 2.0f * p1 * u * v + p2 * (r2 + 2.0f * u * u);
    const float vd = v * radial + p1 * (r2 + 2.0f * v * v) + 2.0f * p2 * u * v;
    // +0.5 in cx, cy: truncation is rounding to the nearest pixel centre for >= 0.
    const float fu = fx * ud + cx, fv = fy * vd + cy;
    // Bitwise & and clamped conversions: no branch, so the loop runs in SIMD lanes.
    const bool inside =
        (raw[x] != 0) & (pz > 1e-6f) & (fu >= 0.0f) & (fv >= 0.0f) & (fu < w) & (fv < h);
    const int col = static_cast<int>(std::min(std::max(fu, 0.0f), w));
    const int row = static_cast<int>(std::min(std::max(fv, 0.0f), h));
    target[x] = inside ? row * color_width + col : spare;
    value[x] = static_cast<std::uint16_t>(
        static_cast<int>(std::min(std::max(pz * units + 0.5f, 1.0f), 65535.0f)));
  }
}

}  // namespace coloc::capture
