#include "slam/loop/free_space.hpp"

#include <algorithm>
#include <cmath>

#include "slam/core/error.hpp"

namespace coloc::slam::loop {

void FreeSpaceOptions::check() const {
  if (stride < 1) throw Error("FreeSpaceOptions.stride must be >= 1");
  if (!(tolerance_m > 0.0)) throw Error("FreeSpaceOptions.tolerance_m must be > 0");
  if (!(tolerance_ratio >= 0.0)) throw Error("FreeSpaceOptions.tolerance_ratio must be >= 0");
  if (edge_radius < 0 || edge_radius > 8)
    throw Error("FreeSpaceOptions.edge_radius must be in [0, 8]");
}

namespace {

// The nearest valid depth within `radius` small pixels of (u, v); 0 when there is none.
double nearest_around(const map::KeyframeDepth& d, int u, int v, int radius) {
  double nearest = 0.0;
  for (int y = std::max(0, v - radius); y <= std::min(d.height - 1, v + radius); ++y) {
    for (int x = std::max(0, u - radius); x <= std::min(d.width - 1, u + radius); ++x) {
      const double z = d.metres(x, y);
      if (z > 0.0 && (nearest == 0.0 || z < nearest)) nearest = z;
    }
  }
  return nearest;
}

}  // namespace

std::vector<Eigen::Vector3d> depth_samples(const map::KeyframeDepth& depth, const Camera& camera,
                                           const FreeSpaceOptions& o) {
  std::vector<Eigen::Vector3d> samples;
  for (int v = o.stride / 2; v < depth.height; v += o.stride) {
    for (int u = o.stride / 2; u < depth.width; u += o.stride) {
      const double z = depth.metres(u, v);
      if (z > 0.0) samples.push_back(backproject(camera, depth.full_pixel(u, v), z));
    }
  }
  return samples;
}

FreeSpaceCount compare_depth(const std::vector<Eigen::Vector3d>& from_samples,
                             const map::KeyframeDepth& to, const SE3& to_cam_from_from_cam,
                             const Camera& camera, const FreeSpaceOptions& o) {
  FreeSpaceCount count;
  for (const Eigen::Vector3d& sample : from_samples) {
    const Eigen::Vector3d p = to_cam_from_from_cam * sample;
    if (p.z() < 0.05) continue;  // behind the other camera, or at its centre
    const Eigen::Vector2d pixel = project(camera, p);
    // Small pixel (x, y) covers the full-resolution pixels factor x .. factor x + factor - 1,
    // whose centres are whole numbers.
    const double sx = std::floor((pixel.x() + 0.5) / to.factor);
    const double sy = std::floor((pixel.y() + 0.5) / to.factor);
    if (!(sx >= 0.0 && sy >= 0.0 && sx < to.width && sy < to.height)) continue;
    const int x = static_cast<int>(sx), y = static_cast<int>(sy);
    const double z_to = to.metres(x, y);
    if (z_to <= 0.0) continue;
    const double tolerance = o.tolerance_m + o.tolerance_ratio * p.z();
    if (std::abs(p.z() - z_to) <= tolerance) {
      ++count.agree;
    } else if (p.z() > z_to) {
      ++count.occluded;
    } else if (p.z() < nearest_around(to, x, y, o.edge_radius) - tolerance) {
      ++count.violate;
    } else {
      ++count.occluded;  // beside a depth edge of the other view: no evidence
    }
  }
  return count;
}

}  // namespace coloc::slam::loop
