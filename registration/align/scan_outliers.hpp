#pragma once
// Stray returns in a laser scan (dust, reflections, a person walking through, mixed pixels far
// off every surface): drawn as splats they hide what is behind them in the rendering that the
// refinement matches keyframes against, so they are dropped before rendering. A point is stray
// when fewer than `min_neighbours` other points lie within `radius_factor` times its own splat
// side: the splat side follows the scan's local spacing (scan_cloud.hpp), so the test adapts to
// the density that falls off with range, where PCL's global-statistics filter
// (StatisticalOutlierRemoval) would drop whole far walls. The neighbour search is PCL's k-d tree
// (FLANN).
#include <cstddef>

#include "registration/render/scene.hpp"

namespace coloc::registration::align {

struct StrayPointOptions {
  int min_neighbours = 2;      // 0: keep every point
  double radius_factor = 2.0;  // search radius / the point's splat side
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// Removes stray points from `cloud` in place (points, colours and splat sizes together) and
// returns how many were removed.
std::size_t remove_stray_points(render::PointCloud& cloud, const StrayPointOptions& options = {});

}  // namespace coloc::registration::align
