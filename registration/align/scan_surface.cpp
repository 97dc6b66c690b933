#include "registration/align/scan_surface.hpp"

#include <pcl/kdtree/kdtree_flann.h>

#include <cmath>
#include <vector>

#include "registration/align/pcl_normals.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {

void ScanSurfaceOptions::check() const {
  if (!(voxel_size > 0.0 && std::isfinite(voxel_size)))
    throw Error("must be a positive number of metres", {.field = "voxel_size"});
  if (!(normal_radius > voxel_size && std::isfinite(normal_radius)))
    throw Error("must be more than voxel_size (metres)", {.field = "normal_radius"});
  if (!(max_curvature > 0.0 && max_curvature <= 1.0 / 3.0))
    throw Error("must be in (0, 1/3]", {.field = "max_curvature"});
}

struct ScanSurface::Impl {
  NormalCloud::Ptr cloud;
  pcl::KdTreeFLANN<NormalPoint> tree;
};

ScanSurface::ScanSurface(const render::PointCloud& scan, const ScanSurfaceOptions& o)
    : impl_(std::make_unique<Impl>()) {
  o.check();
  const NormalCloud::Ptr all = thinned_with_normals(scan, o.voxel_size, o.normal_radius);
  impl_->cloud = std::make_shared<NormalCloud>();
  for (const NormalPoint& p : *all) {
    if (p.curvature <= o.max_curvature) impl_->cloud->push_back(p);
  }
  if (impl_->cloud->empty())
    throw Error("no planar surface in the scan's " + std::to_string(scan.points.size()) +
                    " points (at " + std::to_string(o.voxel_size) + " m voxels)",
                {.field = "scan"});
  impl_->tree.setInputCloud(impl_->cloud);
}

ScanSurface::~ScanSurface() = default;
ScanSurface::ScanSurface(ScanSurface&&) noexcept = default;
ScanSurface& ScanSurface::operator=(ScanSurface&&) noexcept = default;

std::size_t ScanSurface::size() const {
  return impl_->cloud->size();
}

std::optional<SurfaceHit> ScanSurface::nearest(const Eigen::Vector3d& x,
                                               double max_distance) const {
  if (!x.allFinite()) return std::nullopt;
  NormalPoint query;
  query.x = static_cast<float>(x.x());
  query.y = static_cast<float>(x.y());
  query.z = static_cast<float>(x.z());
  std::vector<int> index(1);
  std::vector<float> d2(1);
  if (impl_->tree.nearestKSearch(query, 1, index, d2) < 1) return std::nullopt;
  if (d2[0] > max_distance * max_distance) return std::nullopt;
  const NormalPoint& p = (*impl_->cloud)[static_cast<std::size_t>(index[0])];
  SurfaceHit hit;
  hit.point = {p.x, p.y, p.z};
  hit.normal = Eigen::Vector3d(p.normal_x, p.normal_y, p.normal_z).normalized();
  hit.distance = std::sqrt(static_cast<double>(d2[0]));
  return hit;
}

}  // namespace coloc::registration::align
