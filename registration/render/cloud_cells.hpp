#pragma once
// A point cloud grouped into cubic cells, so a render draws only the cells its view frustum can
// reach. A site's scan holds millions of points of which a keyframe sees a few rooms; without
// culling every render pushed every point through the (software) vertex stage, so a render's
// cost grew with the site instead of with the view.
//
// The renderer uploads the points cell by cell (order: upload position -> index in the cloud)
// and draws the visible cells as contiguous ranges. Culling is conservative: a cell is dropped
// only when its box, grown by its largest splat, lies wholly outside one plane of the frustum
// widened by the largest on-screen splat, so the image is the same as drawing everything.

#include <Eigen/Geometry>
#include <cstdint>
#include <utility>
#include <vector>

#include "registration/render/scene.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::registration::render {

struct CloudCells {
  struct Cell {
    std::uint32_t first = 0, count = 0;  // range of upload positions
    Eigen::AlignedBox3f box;             // of the cell's points, grown by its largest splat
  };
  std::vector<std::uint32_t> order;  // upload position -> index in the cloud
  std::vector<Cell> cells;           // in upload order
};

// Groups `cloud` into cells of `cell_size` metres (> 0), cells in a fixed order and points in
// cloud order within a cell (deterministic).
CloudCells group_into_cells(const PointCloud& cloud, float cell_size);

// Ranges (first, count) of upload positions to draw for a camera of `camera`'s size (no
// distortion) at `cam_from_world`, adjacent visible cells merged; `margin_pixels` widens the
// image on every side (half the largest splat on screen).
std::vector<std::pair<std::uint32_t, std::uint32_t>> visible_ranges(
    const CloudCells& cells, const PinholeCamera& camera, const SE3& cam_from_world,
    double near_plane, double far_plane, double margin_pixels);

}  // namespace coloc::registration::render
