#include "registration/align/scan_outliers.hpp"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

#include <vector>

#include "slam/core/error.hpp"

namespace coloc::registration::align {

void StrayPointOptions::check() const {
  if (min_neighbours < 0) throw Error("must be >= 0", {.field = "min_neighbours"});
  if (!(radius_factor > 0.0)) throw Error("must be positive", {.field = "radius_factor"});
}

std::size_t remove_stray_points(render::PointCloud& cloud, const StrayPointOptions& o) {
  o.check();
  cloud.check();
  const std::size_t n = cloud.points.size();
  if (o.min_neighbours == 0 || n == 0) return 0;
  auto pcl_cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl_cloud->reserve(n);
  for (const Eigen::Vector3f& p : cloud.points)
    pcl_cloud->push_back({p.x(), p.y(), p.z()});
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(pcl_cloud);
  const bool per_point = !cloud.splat_sizes.empty();
  std::vector<std::uint8_t> keep(n, 0);
  pcl::Indices found;
  std::vector<float> squared;
  for (std::size_t i = 0; i < n; ++i) {
    const float side = per_point ? cloud.splat_sizes[i] : cloud.splat_size;
    const double radius = o.radius_factor * static_cast<double>(side);
    // The point finds itself: min_neighbours others means min_neighbours + 1 hits.
    const int hits = tree.radiusSearch((*pcl_cloud)[i], radius, found, squared,
                                       static_cast<unsigned int>(o.min_neighbours + 1));
    keep[i] = hits > o.min_neighbours ? 1 : 0;
  }
  std::size_t out = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    cloud.points[out] = cloud.points[i];
    cloud.colours[out] = cloud.colours[i];
    if (per_point) cloud.splat_sizes[out] = cloud.splat_sizes[i];
    ++out;
  }
  cloud.points.resize(out);
  cloud.colours.resize(out);
  if (per_point) cloud.splat_sizes.resize(out);
  return n - out;
}

}  // namespace coloc::registration::align
