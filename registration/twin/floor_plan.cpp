#include "registration/twin/floor_plan.hpp"

#include <algorithm>
#include <cmath>

#include "registration/twin/plan_builder.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin {
namespace {

using plan::add_stations;
using plan::PlanBuilder;
using plan::Rect;
using plan::Vec2;

std::vector<Vec2> ellipse(const Vec2& c, double rx, double ry, int n, double start) {
  std::vector<Vec2> out;
  for (int k = 0; k <= n; ++k) {
    const double a = start + 2.0 * M_PI * k / n;
    out.emplace_back(c.x() + rx * std::cos(a), c.y() + ry * std::sin(a));
  }
  return out;
}

void room_preset(FloorPlan& plan) {
  PlanBuilder b(plan, 6.6, 5.1);
  b.add_room("room", {{0.3, 0.3}, {6.3, 4.8}});
  plan.path = ellipse({3.3, 2.55}, 1.5, 0.9, 12, -M_PI / 2);
  add_stations(plan, {{1.9, 1.7}, {4.7, 3.3}});
}

void floor_preset(FloorPlan& plan) {
  PlanBuilder b(plan, 20.6, 10.6);
  const int corridor = b.add_room("corridor", {{0.3, 4.5}, {20.3, 6.3}});
  b.add_room("south-1", {{0.3, 0.3}, {6.8, 4.3}});
  b.add_room("south-2", {{7.0, 0.3}, {13.5, 4.3}});
  b.add_room("south-3", {{13.7, 0.3}, {20.3, 4.3}});
  b.add_room("north-1", {{0.3, 6.5}, {10.2, 10.3}});
  const int n2 = b.add_room("north-2", {{10.4, 6.5}, {20.3, 10.3}});
  for (double x : {4.5, 9.5, 16.0})
    b.door({{x, 4.2}, {x + 1.0, 4.6}}, corridor);
  b.door({{3.0, 6.2}, {4.0, 6.6}}, corridor);
  b.door({{15.0, 6.2}, {16.0, 6.6}}, n2);
  plan.path = {{1.5, 5.4},  {3.5, 5.4},  {5.0, 5.4},  {5.0, 3.4},  {3.6, 2.1},  {1.9, 2.2},
               {2.4, 3.4},  {4.2, 3.3},  {5.0, 4.6},  {6.5, 5.4},  {9.0, 5.4},  {11.5, 5.4},
               {14.0, 5.4}, {15.5, 5.6}, {15.5, 7.4}, {17.5, 8.4}, {15.5, 9.5}, {13.0, 8.4},
               {15.0, 7.0}, {16.0, 5.4}, {17.5, 5.4}, {19.2, 5.4}};
  add_stations(plan, {{3.0, 5.4},
                      {10.0, 5.4},
                      {17.5, 5.4},
                      {3.5, 2.3},
                      {10.2, 2.3},
                      {17.0, 2.3},
                      {6.5, 8.4},
                      {17.5, 8.6}});
}

void building_preset(FloorPlan& plan) {
  PlanBuilder b(plan, 24.6, 16.6);
  const int corridor = b.add_room("corridor", {{0.3, 0.3}, {24.3, 16.3}});
  b.carve({{2.3, 2.3}, {22.3, 14.3}}, -1, 0.0);
  const int r1 = b.add_room("room-1", {{2.5, 2.5}, {12.2, 8.2}});
  b.add_room("room-2", {{12.4, 2.5}, {22.1, 8.2}});
  b.add_room("room-3", {{2.5, 8.4}, {12.2, 14.1}});
  b.add_room("room-4", {{12.4, 8.4}, {22.1, 14.1}});
  b.door({{6.0, 2.2}, {7.0, 2.6}}, corridor);
  b.door({{17.0, 2.2}, {18.0, 2.6}}, corridor);
  b.door({{6.0, 14.0}, {7.0, 14.4}}, corridor);
  b.door({{17.0, 14.0}, {18.0, 14.4}}, corridor);
  b.door({{12.1, 10.5}, {12.5, 11.5}}, r1 + 2);  // room-3 to room-4
  plan.path = {{3.5, 1.3},   {5.0, 1.3},   {6.5, 1.3},   {6.5, 3.4},   {8.5, 4.8},   {10.0, 6.3},
               {7.5, 7.0},   {4.5, 6.0},   {4.2, 4.0},   {6.0, 3.3},   {6.6, 1.6},   {8.5, 1.3},
               {11.0, 1.3},  {14.0, 1.3},  {17.0, 1.3},  {20.0, 1.3},  {22.6, 1.5},  {23.3, 3.5},
               {23.3, 6.0},  {23.3, 8.5},  {23.3, 11.0}, {23.3, 13.5}, {22.8, 15.2}, {20.0, 15.3},
               {17.0, 15.3}, {14.0, 15.3}, {11.0, 15.3}, {8.0, 15.3},  {5.0, 15.3},  {2.0, 15.1},
               {1.3, 13.0},  {1.3, 10.5},  {1.3, 8.0},   {1.3, 5.5},   {1.3, 3.0},   {1.8, 1.4},
               {3.5, 1.3},   {5.5, 1.3}};
  add_stations(plan, {{1.3, 1.3},
                      {12.3, 1.3},
                      {23.3, 1.3},
                      {23.3, 8.3},
                      {23.3, 15.3},
                      {12.3, 15.3},
                      {1.3, 15.3},
                      {1.3, 8.3},
                      {7.3, 5.3},
                      {17.2, 5.3},
                      {7.3, 11.2},
                      {17.2, 11.2}});
}

double distance_to_rect(const Vec2& p, const Rect& r) {
  const Vec2 q = p.cwiseMax(r.min).cwiseMin(r.max);
  return (p - q).norm();
}

double rect_to_polyline(const Rect& r, const std::vector<Vec2>& line) {
  double best = std::numeric_limits<double>::max();
  for (std::size_t k = 0; k + 1 < line.size(); ++k) {
    for (int s = 0; s <= 20; ++s) {
      best = std::min(best, distance_to_rect(line[k] + (line[k + 1] - line[k]) * s / 20.0, r));
    }
  }
  return best;
}

struct WallSpot {
  int i, j;    // free cell in front of the wall
  int di, dj;  // direction from the cell into the wall
  int room;
};

std::vector<WallSpot> straight_wall_spots(const FloorPlan& plan, int half_width) {
  std::vector<WallSpot> out;
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (int j = 0; j < plan.ny; ++j) {
    for (int i = 0; i < plan.nx; ++i) {
      if (!plan.free(i, j)) continue;
      const int room = plan.label[static_cast<std::size_t>(plan.index(i, j))];
      for (const auto& d : dirs) {
        bool ok = true;
        for (int k = -half_width; k <= half_width && ok; ++k) {
          const int ci = i + k * d[1], cj = j + k * d[0];  // tangent = (d[1], d[0])
          ok =
              plan.free(ci, cj) && !plan.free(ci + d[0], cj + d[1]) &&
              plan.label[static_cast<std::size_t>(plan.index(ci, cj))] == room &&
              plan.ceiling[static_cast<std::size_t>(plan.index(ci, cj))] >= plan.room_height - 1e-3;
        }
        if (ok) out.push_back({i, j, d[0], d[1], room});
      }
    }
  }
  return out;
}

bool near_door(const FloorPlan& plan, const Vec2& p, double radius) {
  const int r = static_cast<int>(std::ceil(radius / plan.cell));
  const int ci = static_cast<int>(p.x() / plan.cell), cj = static_cast<int>(p.y() / plan.cell);
  for (int j = cj - r; j <= cj + r; ++j) {
    for (int i = ci - r; i <= ci + r; ++i) {
      if (!plan.free(i, j)) continue;
      if (plan.ceiling[static_cast<std::size_t>(plan.index(i, j))] < plan.room_height - 1e-3) {
        return true;
      }
    }
  }
  return false;
}

void place_markers(FloorPlan& plan, int count, std::mt19937_64& rng) {
  std::vector<WallSpot> spots = straight_wall_spots(plan, 3);
  std::shuffle(spots.begin(), spots.end(), rng);
  std::uniform_real_distribution<double> height(1.1, 1.7);
  const std::size_t rooms = plan.rooms.size();
  std::vector<std::size_t> next(rooms, 0);
  for (int round = 0; static_cast<int>(plan.markers.size()) < count && round < count * 4; ++round) {
    const int room = round % static_cast<int>(rooms);
    for (std::size_t& k = next[static_cast<std::size_t>(room)]; k < spots.size(); ++k) {
      const WallSpot& s = spots[k];
      if (s.room != room) continue;
      Vec2 c((s.i + 0.5) * plan.cell, (s.j + 0.5) * plan.cell);
      c += 0.5 * plan.cell * Vec2(s.di, s.dj);  // onto the wall face
      const bool crowded = std::any_of(plan.markers.begin(), plan.markers.end(), [&](auto& m) {
        return (m.centre.template head<2>() - c).norm() < 1.5;
      });
      if (crowded || near_door(plan, c, 0.8)) continue;
      const Eigen::Vector3d normal(-s.di, -s.dj, 0.0);
      plan.markers.push_back({static_cast<int>(plan.markers.size()),
                              Eigen::Vector3d(c.x(), c.y(), height(rng)) + 0.002 * normal, normal});
      ++k;
      break;
    }
  }
}

// The site's rule, as a surveyor places them: each room's markers on walls of different
// directions first (a rectangle has four) and a room's markers at least `spread` apart, so a
// corridor's markers are strung along it rather than bunched at one end. The markers are dealt
// round-robin over the rooms, so every room gets its share before any gets more.
void place_markers_surveyed(FloorPlan& plan, int count, std::mt19937_64& rng) {
  std::vector<WallSpot> spots = straight_wall_spots(plan, 3);
  std::shuffle(spots.begin(), spots.end(), rng);
  std::uniform_real_distribution<double> height(1.1, 1.7);
  const int rooms = static_cast<int>(plan.rooms.size());
  const double per_room = std::ceil(static_cast<double>(count) / rooms);
  std::vector<std::vector<std::size_t>> candidates(static_cast<std::size_t>(rooms));
  for (std::size_t k = 0; k < spots.size(); ++k)
    candidates[static_cast<std::size_t>(spots[k].room)].push_back(k);
  std::vector<int> marker_room;
  const auto centre = [&](const WallSpot& s) {
    return Vec2((s.i + 0.5 + 0.5 * s.di) * plan.cell, (s.j + 0.5 + 0.5 * s.dj) * plan.cell);
  };
  for (int round = 0; static_cast<int>(plan.markers.size()) < count && round < count * 4; ++round) {
    const int room = round % rooms;
    const Room& r = plan.rooms[static_cast<std::size_t>(room)];
    const double spread = std::max(1.5, 0.7 * (r.max - r.min).maxCoeff() / per_room);
    auto& cand = candidates[static_cast<std::size_t>(room)];
    std::ptrdiff_t pick = -1;
    std::ptrdiff_t fallback = -1;
    for (std::size_t at = 0; at < cand.size() && pick < 0;) {
      const WallSpot& s = spots[cand[at]];
      const Vec2 c = centre(s);
      bool crowded = near_door(plan, c, 0.8);
      bool used_wall = false;
      for (std::size_t m = 0; m < plan.markers.size() && !crowded; ++m) {
        const double d = (plan.markers[m].centre.head<2>() - c).norm();
        const bool same_room = marker_room[m] == room;
        crowded = d < 1.5 || (same_room && d < spread);
        used_wall = used_wall || (same_room && plan.markers[m].normal.x() == -s.di &&
                                  plan.markers[m].normal.y() == -s.dj);
      }
      if (crowded) {  // markers are only ever added: a crowded spot stays crowded
        cand.erase(cand.begin() + static_cast<std::ptrdiff_t>(at));
        continue;
      }
      if (!used_wall) pick = static_cast<std::ptrdiff_t>(at);
      if (fallback < 0) fallback = static_cast<std::ptrdiff_t>(at);
      ++at;
    }
    if (pick < 0) pick = fallback;
    if (pick < 0) continue;  // this room is full
    const WallSpot& s = spots[cand[static_cast<std::size_t>(pick)]];
    const Vec2 c = centre(s);
    const Eigen::Vector3d normal(-s.di, -s.dj, 0.0);
    plan.markers.push_back({static_cast<int>(plan.markers.size()),
                            Eigen::Vector3d(c.x(), c.y(), height(rng)) + 0.002 * normal, normal});
    marker_room.push_back(room);
    cand.erase(cand.begin() + pick);
  }
}

void place_furniture(FloorPlan& plan, const FloorPlanOptions& o, std::mt19937_64& rng) {
  struct Kind {
    double length, depth, height;
    int texture;  // offset within the furniture textures
  };
  const Kind kinds[] = {{1.4, 0.7, 0.75, 0},
                        {0.9, 0.45, 1.0, 0},
                        {1.0, 0.35, 1.9, 2},
                        {1.8, 0.8, 0.8, 1},
                        {0.6, 0.6, 0.5, 1}};
  std::vector<WallSpot> spots = straight_wall_spots(plan, 1);
  std::shuffle(spots.begin(), spots.end(), rng);
  std::uniform_int_distribution<int> pick(0, 4);
  const int base = o.wall_textures + o.floor_textures;
  std::vector<int> placed(plan.rooms.size(), 0);
  for (const WallSpot& s : spots) {
    const Room& room = plan.rooms[static_cast<std::size_t>(s.room)];
    const double area = (room.max - room.min).prod();
    if (placed[static_cast<std::size_t>(s.room)] >= std::max(2, static_cast<int>(area / 5.0)))
      continue;
    const Kind& k = kinds[pick(rng)];
    const Vec2 wall((s.i + 0.5 + 0.5 * s.di) * plan.cell, (s.j + 0.5 + 0.5 * s.dj) * plan.cell);
    const Vec2 inward(-s.di, -s.dj), along(std::abs(s.dj), std::abs(s.di));
    const Vec2 a = wall + 0.02 * inward - 0.5 * k.length * along;
    const Vec2 b = wall + (0.02 + k.depth) * inward + 0.5 * k.length * along;
    const Rect r{a.cwiseMin(b), a.cwiseMax(b)};
    bool ok = plan.is_free(r.min) && plan.is_free(r.max) && plan.is_free({r.min.x(), r.max.y()}) &&
              plan.is_free({r.max.x(), r.min.y()});
    ok = ok && rect_to_polyline(r, plan.path) > 0.6 &&
         !near_door(plan, 0.5 * (r.min + r.max), 0.5 * k.length + 0.9);
    for (const auto& st : plan.stations)
      ok = ok && distance_to_rect(st.head<2>(), r) > 0.8;
    for (const auto& m : plan.markers)
      ok = ok && distance_to_rect(m.centre.head<2>(), r) > 0.9;
    for (const Box& f : plan.furniture) {
      const Rect fr{f.min.head<2>(), f.max.head<2>()};
      ok = ok && !((r.min.array() < fr.max.array() + 0.15).all() &&
                   (fr.min.array() < r.max.array() + 0.15).all());
    }
    if (!ok) continue;
    plan.furniture.push_back({Eigen::Vector3d(r.min.x(), r.min.y(), 0.0),
                              Eigen::Vector3d(r.max.x(), r.max.y(), k.height),
                              base + k.texture % o.furniture_textures});
    ++placed[static_cast<std::size_t>(s.room)];
  }
}

}  // namespace

Preset parse_preset(const std::string& name) {
  if (name == "room") return Preset::kRoom;
  if (name == "floor") return Preset::kFloor;
  if (name == "building") return Preset::kBuilding;
  if (name == "site") return Preset::kSite;
  throw Error("unknown preset '" + name + "' (room, floor, building or site)", {.field = "preset"});
}

std::string preset_name(Preset preset) {
  switch (preset) {
    case Preset::kRoom:
      return "room";
    case Preset::kFloor:
      return "floor";
    case Preset::kBuilding:
      return "building";
    case Preset::kSite:
      return "site";
  }
  return "room";
}

bool FloorPlan::is_free(const Eigen::Vector2d& p) const {
  return free(static_cast<int>(std::floor(p.x() / cell)),
              static_cast<int>(std::floor(p.y() / cell)));
}

FloorPlan make_floor_plan(const FloorPlanOptions& options, std::mt19937_64& rng) {
  FloorPlan plan;
  int markers = 6;
  switch (options.preset) {
    case Preset::kRoom:
      room_preset(plan);
      break;
    case Preset::kFloor:
      floor_preset(plan);
      markers = 14;
      break;
    case Preset::kBuilding:
      building_preset(plan);
      markers = 24;
      break;
    case Preset::kSite:
      plan::site_preset(plan);
      markers = 4 * static_cast<int>(plan.rooms.size());  // one per wall of each room
      break;
  }
  for (std::size_t r = 0; r < plan.rooms.size(); ++r) {
    plan.rooms[r].wall_texture = static_cast<int>(r) % options.wall_textures;
    plan.rooms[r].floor_texture =
        options.wall_textures + static_cast<int>(r) % options.floor_textures;
  }
  markers = std::min(markers, options.marker_dictionary_size);
  if (options.preset == Preset::kSite) {
    place_markers_surveyed(plan, markers, rng);
  } else {
    place_markers(plan, markers, rng);  // kept as it was: the older presets' files stay the same
  }
  place_furniture(plan, options, rng);
  return plan;
}

int move_furniture(FloorPlan& plan, int count, double shift) {
  const int n = static_cast<int>(plan.furniture.size());
  int moved = 0;
  for (int k = 0; k < std::min(count, n); ++k) {
    const auto index = static_cast<std::size_t>((k * n) / std::max(count, 1));
    Box& box = plan.furniture[index];
    const Rect old{box.min.head<2>(), box.max.head<2>()};
    // Furniture stands with its long side against the wall: slide along that side.
    const Vec2 size = old.max - old.min;
    const Vec2 along = size.x() >= size.y() ? Vec2(1.0, 0.0) : Vec2(0.0, 1.0);
    for (const double sign : {1.0, -1.0}) {
      const Rect r{old.min + sign * shift * along, old.max + sign * shift * along};
      bool ok = plan.is_free(r.min) && plan.is_free(r.max) &&
                plan.is_free({r.min.x(), r.max.y()}) && plan.is_free({r.max.x(), r.min.y()}) &&
                rect_to_polyline(r, plan.path) > 0.6;
      for (std::size_t f = 0; f < plan.furniture.size() && ok; ++f) {
        if (f == index) continue;
        const Rect fr{plan.furniture[f].min.head<2>(), plan.furniture[f].max.head<2>()};
        ok = !((r.min.array() < fr.max.array() + 0.15).all() &&
               (fr.min.array() < r.max.array() + 0.15).all());
      }
      if (!ok) continue;
      box.min.head<2>() = r.min;
      box.max.head<2>() = r.max;
      ++moved;
      break;
    }
  }
  return moved;
}

}  // namespace coloc::registration::twin
