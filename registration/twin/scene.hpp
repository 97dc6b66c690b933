#pragma once
// The twin's scene: the floor plan turned into one textured mesh (walls, floors, ceilings,
// furniture, ArUco markers), with the exact pose and corners of every marker. World frame:
// x east, y north, z up, metres; this is also the laser scan's frame.

#include <array>
#include <cstdint>
#include <vector>

#include "registration/render/scene.hpp"
#include "registration/twin/floor_plan.hpp"
#include "slam/core/se3.hpp"

namespace coloc::registration::twin {

struct SceneOptions {
  Preset preset = Preset::kRoom;
  int dictionary = 0;           // OpenCV predefined dictionary id; 0 = DICT_4X4_50
  double marker_size = 0.1675;  // edge of the black square, metres
  int texture_size = 1024;      // pixels per procedural texture (covers 2 m x 2 m)
  double texture_tile = 2.0;    // metres covered by one texture repeat
  // Pieces of furniture moved 0.8 m along their wall after planning (move_furniture): the
  // sequence's scene when the scan shows the old places.
  int moved_furniture = 0;

  void check() const;  // throws coloc::Error naming the bad field
};

// Ground truth of one marker. Marker frame as OpenCV's ArUco: origin at the centre, x to the
// right and y up as seen from the front, z out of the wall towards the viewer.
struct MarkerTruth {
  int id = 0;
  double size = 0.0;  // metres
  SE3 world_from_marker;
  // Corners in OpenCV's order (top-left, top-right, bottom-right, bottom-left as seen from the
  // front), world frame, metres.
  std::array<Eigen::Vector3d, 4> corners;
};

struct TwinScene {
  FloorPlan plan;
  render::TexturedMesh mesh;
  std::vector<MarkerTruth> markers;
  int dictionary = 0;
  int moved_furniture = 0;  // pieces actually moved (SceneOptions::moved_furniture asked)
};

// Deterministic in (options, seed).
TwinScene build_scene(const SceneOptions& options, std::uint64_t seed);

}  // namespace coloc::registration::twin
