// The site preset: the scale of the paper's sites (160-312 m2 tracked over 5-9 rooms, 800
// keyframes, scans of 205-1,058 million points). One storey, since neither the renderer's scenes
// nor the walk have stairs:
//
//   y 19.9  +----------+----------+----------+----------+
//           |  north-1 | north-2  | north-3  = north-4  |     = room-to-room door
//   y 14.4  |  lobby   +--------- corridor-north ---+ c |
//           |          | middle-1 = middle-2 | mid-3 | o |     corridor-east joins both
//   y  7.5  |          +--------- corridor-south ---+ r |     corridors: a loop through the lobby
//           |  south-1 | south-2  = south-3  | south-4  |
//   y  0    +----------+----------+----------+----------+
//           x 0                                     x 30.5
//
// Every room has a 1.2 m door to the corridor or lobby (the middle rooms one to each corridor),
// three room-to-room doors. The survey walk enters every room, goes once around it 1.5 m from its
// walls and leaves, and closes three loops through the corridors and the lobby.

#include <cmath>
#include <string>

#include "registration/twin/plan_builder.hpp"

namespace coloc::registration::twin::plan {
namespace {

// The walk's distance from a room's walls inside it: furniture (at most 0.82 m deep) then stays
// more than the 0.6 m place_furniture keeps from the path, so rooms keep furniture on all walls.
constexpr double kInset = 1.5;
constexpr double kDoorHalf = 0.6;  // 1.2 m doors: 0.6 m clearance on the path, 0.35 m on walks 1/2

// Perimeter coordinate of a point on rectangle r's boundary, counter-clockwise from r.min.
double perimeter_at(const Rect& r, const Vec2& p) {
  const double w = r.max.x() - r.min.x(), h = r.max.y() - r.min.y();
  if (std::abs(p.y() - r.min.y()) < 1e-9) return p.x() - r.min.x();
  if (std::abs(p.x() - r.max.x()) < 1e-9) return w + p.y() - r.min.y();
  if (std::abs(p.y() - r.max.y()) < 1e-9) return w + h + r.max.x() - p.x();
  return 2.0 * w + h + r.max.y() - p.y();
}

void add(std::vector<Vec2>& path, const Vec2& p) {
  if (path.empty() || (path.back() - p).norm() > 1e-9) path.push_back(p);
}

// Walks from the corridor point `before` through the door centred at `in` into `room`, once
// around it kInset from its walls, on along the loop to the door `out` and out to `after`.
void visit_room(std::vector<Vec2>& path, const Rect& room, const Vec2& before, const Vec2& in,
                const Vec2& out, const Vec2& after) {
  const Rect loop{room.min + Vec2::Constant(kInset), room.max - Vec2::Constant(kInset)};
  const Vec2 enter = in.cwiseMax(loop.min).cwiseMin(loop.max);
  const Vec2 leave = out.cwiseMax(loop.min).cwiseMin(loop.max);
  const double w = loop.max.x() - loop.min.x(), h = loop.max.y() - loop.min.y();
  const double perimeter = 2.0 * (w + h);
  const double s0 = perimeter_at(loop, enter);
  const double s1 =
      s0 + perimeter + std::fmod(perimeter_at(loop, leave) - s0 + perimeter, perimeter);
  const Vec2 corners[4] = {
      loop.min, {loop.max.x(), loop.min.y()}, loop.max, {loop.min.x(), loop.max.y()}};
  const double corner_at[4] = {0.0, w, w + h, 2.0 * w + h};
  add(path, before);
  add(path, in);
  add(path, enter);
  for (int lap = 0; lap < 3; ++lap) {
    for (int k = 0; k < 4; ++k) {
      const double s = corner_at[k] + lap * perimeter;
      if (s > s0 + 1e-9 && s < s1 - 1e-9) add(path, corners[k]);
    }
  }
  add(path, leave);
  add(path, out);
  add(path, after);
}

}  // namespace

void site_preset(FloorPlan& plan) {
  PlanBuilder b(plan, 30.5, 19.9);
  // Rows south to north: rooms, corridor (centre line y = 6.5), rooms, corridor (y = 13.4),
  // rooms; 0.2 m walls between them.
  const double sy0 = 0.3, sy1 = 5.3, cs0 = 5.5, cs1 = 7.5, my0 = 7.7, my1 = 12.2, cn0 = 12.4,
               cn1 = 14.4, ny0 = 14.6, ny1 = 19.6;
  const double cs = 0.5 * (cs0 + cs1), cn = 0.5 * (cn0 + cn1), ce = 29.2;
  const int lobby = b.add_room("lobby", {{0.3, cs0}, {6.0, cn1}});
  const int south = b.add_room("corridor-south", {{6.0, cs0}, {28.2, cs1}});
  const int north = b.add_room("corridor-north", {{6.0, cn0}, {28.2, cn1}});
  b.add_room("corridor-east", {{28.2, cs0}, {30.2, cn1}});
  const double xs[5] = {0.3, 7.6, 15.1, 22.6, 30.2};  // outer rooms' walls (0.2 m wide)
  const double xm[4] = {6.2, 13.4, 20.8, 28.0};       // middle rooms
  const double door_x[4] = {3.2, 11.4, 19.0, 25.5};   // outer rooms' doors
  const double mdoor_x[3] = {9.8, 17.2, 24.5};
  Rect south_room[4], north_room[4], middle_room[3];
  int south_id[4], north_id[4], middle_id[3];
  for (int k = 0; k < 4; ++k) {
    const double x0 = k == 0 ? xs[0] : xs[k] + 0.2;
    south_room[k] = {{x0, sy0}, {xs[k + 1], sy1}};
    north_room[k] = {{x0, ny0}, {xs[k + 1], ny1}};
    south_id[k] = b.add_room("south-" + std::to_string(k + 1), south_room[k]);
    const int corridor = k == 0 ? lobby : south;
    b.door({{door_x[k] - kDoorHalf, sy1 - 0.1}, {door_x[k] + kDoorHalf, cs0 + 0.1}}, corridor);
  }
  for (int k = 0; k < 3; ++k) {
    middle_room[k] = {{k == 0 ? xm[0] : xm[k] + 0.2, my0}, {xm[k + 1], my1}};
    middle_id[k] = b.add_room("middle-" + std::to_string(k + 1), middle_room[k]);
    b.door({{mdoor_x[k] - kDoorHalf, cs1 - 0.1}, {mdoor_x[k] + kDoorHalf, my0 + 0.1}}, south);
    b.door({{mdoor_x[k] - kDoorHalf, my1 - 0.1}, {mdoor_x[k] + kDoorHalf, cn0 + 0.1}}, north);
  }
  for (int k = 0; k < 4; ++k) {
    north_id[k] = b.add_room("north-" + std::to_string(k + 1), north_room[k]);
    const int corridor = k == 0 ? lobby : north;
    b.door({{door_x[k] - kDoorHalf, cn1 - 0.1}, {door_x[k] + kDoorHalf, ny0 + 0.1}}, corridor);
  }
  // Room-to-room doors (south-2/3, middle-1/2, north-3/4): other ways round, other views.
  b.door({{15.0, 1.9}, {15.4, 3.1}}, south_id[1]);
  b.door({{13.3, 9.35}, {13.7, 10.55}}, middle_id[0]);
  b.door({{22.5, 16.5}, {22.9, 17.7}}, north_id[2]);

  // The survey walk. Lap 1: from the lobby through the south rooms eastwards, up the east
  // corridor and through the north rooms westwards, back into the lobby (loop 1).
  std::vector<Vec2>& p = plan.path;
  add(p, {1.6, 10.0});
  visit_room(p, south_room[0], {door_x[0], 6.7}, {door_x[0], cs0 - 0.1}, {door_x[0], cs0 - 0.1},
             {door_x[0], 6.7});
  for (int k = 1; k < 4; ++k) {
    const Vec2 c(door_x[k], cs);
    visit_room(p, south_room[k], c, {door_x[k], cs0 - 0.1}, {door_x[k], cs0 - 0.1}, c);
  }
  add(p, {ce, cs});
  add(p, {ce, cn});
  for (int k = 3; k >= 1; --k) {
    const Vec2 c(door_x[k], cn);
    visit_room(p, north_room[k], c, {door_x[k], cn1 + 0.1}, {door_x[k], cn1 + 0.1}, c);
  }
  add(p, {6.0, cn});
  visit_room(p, north_room[0], {door_x[0], 12.2}, {door_x[0], cn1 + 0.1}, {door_x[0], cn1 + 0.1},
             {door_x[0], 12.2});
  add(p, {3.1, 10.0});
  // Lap 2: the middle rooms, each in through one corridor and out into the other, then back
  // along the south corridor into the lobby (loop 2).
  add(p, {5.0, cs});
  const Vec2 ms0(mdoor_x[0], cs), mn0(mdoor_x[0], cn), mn1(mdoor_x[1], cn), ms1(mdoor_x[1], cs);
  const Vec2 ms2(mdoor_x[2], cs), mn2(mdoor_x[2], cn);
  visit_room(p, middle_room[0], ms0, {mdoor_x[0], cs1 + 0.1}, {mdoor_x[0], cn0 - 0.1}, mn0);
  visit_room(p, middle_room[1], mn1, {mdoor_x[1], cn0 - 0.1}, {mdoor_x[1], cs1 + 0.1}, ms1);
  visit_room(p, middle_room[2], ms2, {mdoor_x[2], cs1 + 0.1}, {mdoor_x[2], cn0 - 0.1}, mn2);
  add(p, {ce, cn});
  add(p, {ce, cs});
  add(p, {6.0, cs});
  add(p, {3.1, 8.5});
  // Lap 3: the whole corridor ring once more, north-about (loop 3), ending in the lobby.
  add(p, {3.1, 11.5});
  add(p, {6.0, cn});
  add(p, {ce, cn});
  add(p, {ce, cs});
  add(p, {6.0, cs});
  add(p, {1.8, 9.0});

  // Stations: one in the middle of every room, two in the lobby, the corridors every ~7 m.
  std::vector<Vec2> st;
  for (const Rect* rooms : {south_room, north_room}) {
    for (int k = 0; k < 4; ++k)
      st.push_back(0.5 * (rooms[k].min + rooms[k].max));
  }
  for (const Rect& r : middle_room)
    st.push_back(0.5 * (r.min + r.max));
  st.insert(st.end(), {{3.1, 8.0}, {3.1, 12.0}, {ce, cs}, {ce, cn}});
  for (double x : {9.0, 15.7, 22.4}) {
    st.emplace_back(x, cs);
    st.emplace_back(x, cn);
  }
  add_stations(plan, st);
}

}  // namespace coloc::registration::twin::plan
