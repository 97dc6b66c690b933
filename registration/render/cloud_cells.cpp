#include "registration/render/cloud_cells.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace coloc::registration::render {
namespace {

// 21 bits per axis: +-1,048,576 cells, far beyond any building at a metre per cell.
std::uint64_t cell_key(const Eigen::Vector3f& p, float cell_size) {
  const auto axis = [&](float v) {
    const auto i = static_cast<std::int64_t>(std::floor(v / cell_size)) + (1 << 20);
    return static_cast<std::uint64_t>(std::clamp<std::int64_t>(i, 0, (1 << 21) - 1));
  };
  return (axis(p.x()) << 42) | (axis(p.y()) << 21) | axis(p.z());
}

}  // namespace

CloudCells group_into_cells(const PointCloud& cloud, float cell_size) {
  CloudCells out;
  const std::size_t n = cloud.points.size();
  std::vector<std::uint64_t> keys(n);
  for (std::size_t i = 0; i < n; ++i)
    keys[i] = cell_key(cloud.points[i], cell_size);
  out.order.resize(n);
  std::iota(out.order.begin(), out.order.end(), 0u);
  std::stable_sort(out.order.begin(), out.order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  for (std::uint32_t pos = 0; pos < n;) {
    CloudCells::Cell cell;
    cell.first = pos;
    const std::uint64_t key = keys[out.order[pos]];
    float splat = cloud.splat_size;
    for (; pos < n && keys[out.order[pos]] == key; ++pos) {
      const std::uint32_t i = out.order[pos];
      cell.box.extend(cloud.points[i]);
      if (!cloud.splat_sizes.empty()) splat = std::max(splat, cloud.splat_sizes[i]);
    }
    cell.count = pos - cell.first;
    const Eigen::Vector3f grow = Eigen::Vector3f::Constant(splat);
    cell.box = Eigen::AlignedBox3f(cell.box.min() - grow, cell.box.max() + grow);
    out.cells.push_back(cell);
  }
  return out;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> visible_ranges(
    const CloudCells& cells, const PinholeCamera& camera, const SE3& cam_from_world,
    double near_plane, double far_plane, double margin_pixels) {
  const Eigen::Matrix3d rotation = cam_from_world.rotation();
  const Eigen::Vector3d translation = cam_from_world.translation();
  const double m = margin_pixels;
  // The frustum's half-spaces in the camera frame, a . (x, y, z) >= 0 inside (the side planes
  // pass through the centre), so corners behind the camera are judged correctly too.
  const std::array<Eigen::Vector3d, 4> sides{
      Eigen::Vector3d(camera.fx, 0.0, camera.cx + m),                        // u >= -m
      Eigen::Vector3d(-camera.fx, 0.0, camera.width - 1.0 - camera.cx + m),  // u <= w - 1 + m
      Eigen::Vector3d(0.0, camera.fy, camera.cy + m),
      Eigen::Vector3d(0.0, -camera.fy, camera.height - 1.0 - camera.cy + m)};
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ranges;
  for (const CloudCells::Cell& cell : cells.cells) {
    std::array<Eigen::Vector3d, 8> corners;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3f c = cell.box.corner(static_cast<Eigen::AlignedBox3f::CornerType>(k));
      corners[static_cast<std::size_t>(k)] = rotation * c.cast<double>() + translation;
    }
    const auto all_outside = [&](auto&& outside) {
      return std::all_of(corners.begin(), corners.end(), outside);
    };
    bool culled = all_outside([&](const Eigen::Vector3d& c) { return c.z() < near_plane; }) ||
                  all_outside([&](const Eigen::Vector3d& c) { return c.z() > far_plane; });
    for (const Eigen::Vector3d& side : sides) {
      if (culled) break;
      culled = all_outside([&](const Eigen::Vector3d& c) { return side.dot(c) < 0.0; });
    }
    if (culled) continue;
    if (!ranges.empty() && ranges.back().first + ranges.back().second == cell.first)
      ranges.back().second += cell.count;
    else
      ranges.emplace_back(cell.first, cell.count);
  }
  return ranges;
}

}  // namespace coloc::registration::render
