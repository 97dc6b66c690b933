#pragma once
// A cloud on a voxel grid with PCL normals and its colour: what the global registration's
// features, ICP and verdict and the scan surface (scan_surface.hpp) are computed on. PCL types:
// include only from .cpp files.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "registration/render/scene.hpp"

namespace coloc::registration::align {

using NormalPoint = pcl::PointXYZRGBNormal;
using NormalCloud = pcl::PointCloud<NormalPoint>;

// `in` on a voxel grid of `voxel` metres, with normals from the neighbours within
// `normal_radius` metres (oriented towards +z where ambiguous, as a scan's floor and a map's);
// points with too few neighbours for a plane are left out.
NormalCloud::Ptr thinned_with_normals(const render::PointCloud& in, double voxel,
                                      double normal_radius);

}  // namespace coloc::registration::align
