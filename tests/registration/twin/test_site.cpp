// The site preset's plan (without rendering it) and the scan's streaming writer.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/aruco.hpp>
#include <random>
#include <set>

#include "e57io/reader.hpp"
#include "registration/render/renderer.hpp"
#include "registration/twin/floor_plan.hpp"
#include "registration/twin/generator.hpp"
#include "registration/twin/scan.hpp"
#include "registration/twin/scene.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::twin {
namespace {

using Vec2 = Eigen::Vector2d;

FloorPlan site_plan(std::uint64_t seed, int dictionary_size = 100) {
  FloorPlanOptions o;
  o.preset = Preset::kSite;
  o.marker_dictionary_size = dictionary_size;
  std::mt19937_64 rng(seed);
  return make_floor_plan(o, rng);
}

int label_at(const FloorPlan& plan, const Vec2& p) {
  const int i = static_cast<int>(std::floor(p.x() / plan.cell));
  const int j = static_cast<int>(std::floor(p.y() / plan.cell));
  return plan.free(i, j) ? plan.label[static_cast<std::size_t>(plan.index(i, j))] : -1;
}

bool is_door(const FloorPlan& plan, const Vec2& p) {
  const int i = static_cast<int>(std::floor(p.x() / plan.cell));
  const int j = static_cast<int>(std::floor(p.y() / plan.cell));
  return plan.ceiling[static_cast<std::size_t>(plan.index(i, j))] < plan.room_height - 1e-3;
}

// Distance from p to the nearest solid cell (searched to 1 m).
double clearance(const FloorPlan& plan, const Vec2& p) {
  double best = 1.0;
  const int ci = static_cast<int>(p.x() / plan.cell), cj = static_cast<int>(p.y() / plan.cell);
  for (int j = cj - 11; j <= cj + 11; ++j) {
    for (int i = ci - 11; i <= ci + 11; ++i) {
      if (plan.free(i, j)) continue;
      const Vec2 lo(i * plan.cell, j * plan.cell);
      const Vec2 q = p.cwiseMax(lo).cwiseMin(lo + Vec2::Constant(plan.cell));
      best = std::min(best, (p - q).norm());
    }
  }
  return best;
}

std::vector<Vec2> samples(const std::vector<Vec2>& path, double spacing) {
  std::vector<Vec2> out;
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const int n =
        std::max(1, static_cast<int>(std::ceil((path[k + 1] - path[k]).norm() / spacing)));
    for (int s = 0; s < n; ++s)
      out.push_back(path[k] + (path[k + 1] - path[k]) * s / n);
  }
  out.push_back(path.back());
  return out;
}

bool is_corridor(const Room& r) {
  return r.name.rfind("corridor", 0) == 0 || r.name == "lobby";
}

TEST(TwinSite, PlanHasThePapersScale) {
  const FloorPlan plan = site_plan(1);
  double area = 0.0;
  for (int l : plan.label)
    area += l >= 0 ? plan.cell * plan.cell : 0.0;
  EXPECT_GE(area, 300.0);
  int rooms = 0;
  for (const Room& r : plan.rooms)
    rooms += is_corridor(r) ? 0 : 1;
  EXPECT_GE(rooms, 8);
  EXPECT_GE(plan.stations.size(), 20u);
  for (const Eigen::Vector3d& s : plan.stations) {
    EXPECT_DOUBLE_EQ(s.z(), 1.5);
    EXPECT_GE(clearance(plan, s.head<2>()), 0.8) << s.transpose();
  }
  // Every room and the lobby has a station.
  std::set<int> scanned;
  for (const Eigen::Vector3d& s : plan.stations)
    scanned.insert(label_at(plan, s.head<2>()));
  for (std::size_t r = 0; r < plan.rooms.size(); ++r) {
    if (!is_corridor(plan.rooms[r]) || plan.rooms[r].name == "lobby") {
      EXPECT_TRUE(scanned.count(static_cast<int>(r))) << plan.rooms[r].name;
    }
  }
  // The defaults scan >= 200 million points (every pixel of a face sees a wall indoors).
  const GenerateOptions o = preset_options(Preset::kSite);
  const double per_face = std::pow(o.scan.face_size / o.scan.point_step, 2);
  EXPECT_GE(static_cast<double>(plan.stations.size()) * 6.0 * per_face, 200e6);
}

TEST(TwinSite, WalkEntersEveryRoomWithClearanceForTenMinutes) {
  const FloorPlan plan = site_plan(1);
  std::map<int, int> inside;  // room -> path samples inside it (not in a door)
  for (const Vec2& p : samples(plan.path, 0.05)) {
    ASSERT_GE(label_at(plan, p), 0) << p.transpose();
    ASSERT_GE(clearance(plan, p), 0.4) << p.transpose();
    if (!is_door(plan, p)) ++inside[label_at(plan, p)];
  }
  for (std::size_t r = 0; r < plan.rooms.size(); ++r) {
    // Once around a room 1.5 m from its walls is > 10 m: 200 samples.
    EXPECT_GE(inside[static_cast<int>(r)], 200) << plan.rooms[r].name;
  }
  // The walk's smoothed track keeps its distance too, and lasts over 10 minutes (18,000 frames at
  // 30 Hz; the test walks, 0.25 m aside, as long).
  const GenerateOptions o = preset_options(Preset::kSite);
  const WalkTrajectory walk(plan.path, o.walk, 1);
  EXPECT_GE(walk.end_time() - walk.start_time(), 600.0);
  for (double t = walk.start_time(); t < walk.end_time(); t += 0.2) {
    const Vec2 p = walk.world_from_cam(t).translation().head<2>();
    ASSERT_GE(clearance(plan, p), 0.35) << "t " << t - walk.start_time();
  }
  // Furniture stands clear of the path.
  for (const Box& f : plan.furniture) {
    for (const Vec2& p : samples(plan.path, 0.1)) {
      const Vec2 q = p.cwiseMax(f.min.head<2>()).cwiseMin(f.max.head<2>());
      ASSERT_GT((p - q).norm(), 0.55);
    }
  }
  EXPECT_GE(plan.furniture.size(), 30u);
}

TEST(TwinSite, EveryRoomHasMarkersOnDifferentWallsWithinTheDictionary) {
  const GenerateOptions o = preset_options(Preset::kSite);
  const int dictionary = cv::aruco::getPredefinedDictionary(o.dictionary)->bytesList.rows;
  for (const int size : {dictionary, 50}) {  // the preset's dictionary, and --dictionary 0
    for (const std::uint64_t seed : {1u, 2u, 3u}) {
      const FloorPlan plan = site_plan(seed, size);
      if (size == dictionary) {
        EXPECT_EQ(plan.markers.size(), 4 * plan.rooms.size());
      }
      std::map<int, std::set<std::pair<int, int>>> walls;  // room -> marker normals
      for (const MarkerPlacement& m : plan.markers) {
        EXPECT_LT(m.id, size);
        const int room = label_at(plan, m.centre.head<2>() + 0.05 * m.normal.head<2>());
        ASSERT_GE(room, 0);
        walls[room].insert({static_cast<int>(m.normal.x()), static_cast<int>(m.normal.y())});
      }
      for (std::size_t r = 0; r < plan.rooms.size(); ++r) {
        EXPECT_GE(walls[static_cast<int>(r)].size(), 2u)
            << plan.rooms[r].name << " seed " << seed << " dictionary " << size;
      }
    }
  }
}

// The streaming writer on a tiny scene: faces large enough to need several batches per face.
TEST(TwinScanWriter, StreamedStationsReadBackWithTheirPointsAndPoses) {
  SceneOptions so;
  so.preset = Preset::kRoom;
  so.texture_size = 128;
  const TwinScene scene = build_scene(so, 4);
  render::Renderer renderer;
  renderer.set_mesh(scene.mesh);
  ScanOptions scan;
  scan.face_size = 320;  // 102,400 points per face > kScanBatch
  scan.point_step = 1;
  const std::filesystem::path dir = coloc::testing::temp_dir("twin_scan_writer");
  ScanCollector memory;
  std::vector<std::size_t> counts;
  {
    ScanFileWriter files(dir / "s.e57", dir / "s.ply", 4, 90);
    for (std::size_t k = 0; k < scene.plan.stations.size(); ++k) {
      const SE3 pose(SO3::exp(Eigen::Vector3d(0, 0, 0.3 * k)), scene.plan.stations[k]);
      const std::size_t before = memory.points.size();
      scan_station(renderer, static_cast<int>(k), pose, scan, 7 + k, memory);
      counts.push_back(memory.points.size() - before);
      scan_station(renderer, static_cast<int>(k), pose, scan, 7 + k, files);
    }
    EXPECT_EQ(files.close(), memory.points.size());
  }
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts[0], 6u * 320 * 320);  // every pixel sees the room
  const e57::Reader reader(dir / "s.e57");
  reader.verify();
  ASSERT_EQ(reader.scans().size(), 2u);
  EXPECT_EQ(reader.images().size(), 12u);
  std::size_t offset = 0;
  for (std::size_t k = 0; k < 2; ++k) {
    const e57::Data3D& d = reader.scans()[k];
    ASSERT_EQ(d.point_count, counts[k]);
    ASSERT_TRUE(d.pose.has_value());
    const SE3& truth = memory.stations[k].world_from_station;
    EXPECT_NEAR(d.pose->translation.x, truth.translation().x(), 1e-12);
    EXPECT_NEAR(d.pose->rotation.w, truth.quaternion().w(), 1e-12);
    const e57::PointBuffer pts = reader.read_points(k);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
    for (std::size_t i = 0; i < counts[k]; ++i) {
      const Eigen::Vector3d& p = memory.points.xyz[offset + i];
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
      ASSERT_NEAR(pts.cartesian_x[i], p.x(), 0.51e-4) << i;
      ASSERT_NEAR(pts.cartesian_y[i], p.y(), 0.51e-4) << i;
      ASSERT_NEAR(pts.cartesian_z[i], p.z(), 0.51e-4) << i;
      ASSERT_EQ(pts.color_green[i], memory.points.rgb[offset + i][1]) << i;
    }
    // Bounds the writer derived chunk by chunk.
    ASSERT_TRUE(d.cartesian_bounds.has_value());
    EXPECT_NEAR(d.cartesian_bounds->x_min, lo.x(), 1e-4);
    EXPECT_NEAR(d.cartesian_bounds->z_max, hi.z(), 1e-4);
    offset += counts[k];
  }
  std::ifstream ply(dir / "s.ply", std::ios::binary);
  std::string header(512, '\0');
  ply.read(header.data(), 512);
  const std::size_t body = header.find("end_header\n") + 11;
  EXPECT_EQ(std::filesystem::file_size(dir / "s.ply") - body, 15u * memory.points.size());
}

}  // namespace
}  // namespace coloc::registration::twin
