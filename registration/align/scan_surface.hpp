#pragma once
// The scan as a surface to measure map geometry against: its points on a voxel grid, each with
// the normal of its neighbourhood, and a k-d tree for the nearest one. The distance of a point x
// to the surface is then n . (x - q) for the nearest grid point q with normal n: a point that
// slides along a wall keeps its distance even where the grid's nearest point changes, which is
// what lets a bundle adjustment pull map geometry onto the scan (surface_ba.hpp).
#include <Eigen/Core>
#include <memory>
#include <optional>

#include "registration/render/scene.hpp"

namespace coloc::registration::align {

struct ScanSurfaceOptions {
  double voxel_size = 0.02;     // metres: grid of the surface points
  double normal_radius = 0.06;  // metres: neighbourhood a normal is fitted to
  // PCL's surface variation (smallest eigenvalue over their sum, 0 on a plane, 1/3 isotropic):
  // points above it (edges, clutter, noise) are not a plane to measure a distance to.
  double max_curvature = 0.08;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SurfaceHit {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // nearest surface point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit
  double distance = 0.0;                             // Euclidean, to `point`
};

class ScanSurface {
 public:
  // Throws coloc::Error (field "scan") when the cloud has no point with a usable normal.
  ScanSurface(const render::PointCloud& scan, const ScanSurfaceOptions& options = {});
  ~ScanSurface();
  ScanSurface(ScanSurface&&) noexcept;
  ScanSurface& operator=(ScanSurface&&) noexcept;

  std::size_t size() const;
  // The nearest planar surface point within `max_distance` metres of `x`, if any.
  std::optional<SurfaceHit> nearest(const Eigen::Vector3d& x, double max_distance) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::registration::align
