#pragma once
// Private to coloc_twin: the pieces the floor-plan presets are drawn with (floor_plan.cpp,
// floor_plan_site.cpp). Metres, world frame (x east, y north), cell centres at (i + 0.5) * cell.

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "registration/twin/floor_plan.hpp"

namespace coloc::registration::twin::plan {

using Vec2 = Eigen::Vector2d;
constexpr double kDoorHeight = 2.1;
constexpr double kStationHeight = 1.5;

struct Rect {
  Vec2 min, max;
};

// Carves rooms and doors into a plan of solid cells: a cell whose centre lies strictly inside a
// rectangle becomes free with that rectangle's label and ceiling.
class PlanBuilder {
 public:
  PlanBuilder(FloorPlan& plan, double width, double depth) : plan_(plan) {
    plan_.nx = static_cast<int>(std::lround(width / plan_.cell));
    plan_.ny = static_cast<int>(std::lround(depth / plan_.cell));
    plan_.label.assign(static_cast<std::size_t>(plan_.nx) * plan_.ny, -1);
    plan_.ceiling.assign(plan_.label.size(), 0.0f);
  }

  int add_room(const std::string& name, Rect r) {
    const int id = static_cast<int>(plan_.rooms.size());
    plan_.rooms.push_back({name, r.min, r.max, 0, 0});
    carve(r, id, plan_.room_height);
    return id;
  }
  void carve(Rect r, int label, double height) {
    for (int j = 0; j < plan_.ny; ++j) {
      for (int i = 0; i < plan_.nx; ++i) {
        const Vec2 c((i + 0.5) * plan_.cell, (j + 0.5) * plan_.cell);
        if ((c.array() > r.min.array()).all() && (c.array() < r.max.array()).all()) {
          const auto k = static_cast<std::size_t>(plan_.index(i, j));
          plan_.label[k] = label;
          plan_.ceiling[k] = label >= 0 ? static_cast<float>(height) : 0.0f;
        }
      }
    }
  }
  // A door is a free cell run through the wall with the lintel's ceiling.
  void door(Rect r, int label) { carve(r, label, kDoorHeight); }

 private:
  FloorPlan& plan_;
};

inline void add_stations(FloorPlan& plan, const std::vector<Vec2>& xy) {
  for (const Vec2& p : xy)
    plan.stations.emplace_back(p.x(), p.y(), kStationHeight);
}

// The site preset's rooms, doors, path and stations (floor_plan_site.cpp).
void site_preset(FloorPlan& plan);

}  // namespace coloc::registration::twin::plan
