#pragma once
// A cloud on a voxel grid with PCL normals: what the global registration's features and ICP and
// the scan surface (scan_surface.hpp) are computed on. PCL types: include only from .cpp files.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "registration/render/scene.hpp"

namespace coloc::registration::align {

using NormalCloud = pcl::PointCloud<pcl::PointNormal>;

// `in` on a voxel grid of `voxel` metres, with normals from the neighbours within
// `normal_radius` metres (oriented towards +z where ambiguous, as a scan's floor and a map's);
// points with too few neighbours for a plane are left out.
NormalCloud::Ptr thinned_with_normals(const render::PointCloud& in, double voxel,
                                      double normal_radius);

}  // namespace coloc::registration::align
