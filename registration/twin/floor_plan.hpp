#pragma once
// The twin's building as a floor plan on a grid of square cells (world frame: x east, y north,
// z up, metres; the floor is z = 0). Free cells belong to a room (or corridor) and have a
// ceiling height; door cells are free cells with a lower ceiling (the lintel). Walls are the
// boundaries between free and solid cells, so the geometry is always closed.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace coloc::registration::twin {

// room: one room (tests, demo); floor: a corridor and 5 rooms; building: a ring corridor around
// 4 rooms; site: the paper's scale, one storey of 11 rooms, a lobby and a corridor loop
// (floor_plan_site.cpp; one floor: the renderer and the walk have no stairs).
enum class Preset { kRoom, kFloor, kBuilding, kSite };
Preset parse_preset(const std::string& name);  // "room" | "floor" | "building" | "site"; throws
std::string preset_name(Preset preset);

struct Room {
  std::string name;
  Eigen::Vector2d min, max;  // metres
  int wall_texture = 0;      // index into the scene's texture list
  int floor_texture = 0;
};

// An axis-aligned box standing on the floor (furniture).
struct Box {
  Eigen::Vector3d min, max;  // metres
  int texture = 0;
};

// An ArUco marker on a wall: centre on the wall face, unit normal pointing into the room.
struct MarkerPlacement {
  int id = 0;
  Eigen::Vector3d centre;
  Eigen::Vector3d normal;
};

struct FloorPlan {
  double cell = 0.1;  // metres
  int nx = 0, ny = 0;
  std::vector<int> label;      // per cell: -1 solid, else room index
  std::vector<float> ceiling;  // per cell: ceiling height (metres); 0 for solid cells
  std::vector<Room> rooms;
  std::vector<Box> furniture;
  std::vector<MarkerPlacement> markers;
  std::vector<Eigen::Vector2d> path;      // walking waypoints, metres (a polyline)
  std::vector<Eigen::Vector3d> stations;  // laser-scanner positions, metres
  double room_height = 2.7;

  int index(int i, int j) const { return j * nx + i; }
  bool free(int i, int j) const {
    return i >= 0 && j >= 0 && i < nx && j < ny &&
           label[static_cast<std::size_t>(index(i, j))] >= 0;
  }
  // True when the point (metres) lies in a free cell.
  bool is_free(const Eigen::Vector2d& p) const;
};

struct FloorPlanOptions {
  Preset preset = Preset::kRoom;
  int marker_dictionary_size = 50;  // ids available (DICT_4X4_50: 50)
  double marker_size = 0.1675;      // black-square edge, metres
  int wall_textures = 4;            // texture ids 0..wall_textures-1 are walls
  int floor_textures = 2;           // then floors
  int furniture_textures = 3;       // then furniture
};

// Builds the preset's rooms, doors, walking path and stations, then places markers and
// furniture at random (from `rng`) where they block neither doors, path nor stations.
FloorPlan make_floor_plan(const FloorPlanOptions& options, std::mt19937_64& rng);

// Objects moved between the scan and the mapping (the paper's moved table): `count` pieces of
// furniture, spread over the plan, slid `shift` metres along their wall where the new place is
// free, clear of the other furniture and as far from the walked path as before (the camera never
// walks through a moved table). Returns how many moved (a piece with no free place stays).
int move_furniture(FloorPlan& plan, int count, double shift);

}  // namespace coloc::registration::twin
