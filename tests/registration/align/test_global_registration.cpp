// Registration without markers or an initial guess (registration/align/global_registration):
// a furnished room sampled as a scan, and a noisy part of it moved into a "map" frame by a
// known transform at several yaws. The transform comes back; with gravity the search is yaw +
// translation only. A symmetric corridor is refused as ambiguous, a map of another room as not
// fitting: named errors, never a silently wrong transform.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numbers>
#include <random>

#include "registration/align/global_registration.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A box's visible faces (or a wall: a box of zero thickness), points every `step` metres with
// `noise` metres of jitter.
struct Sampler {
  render::PointCloud cloud;
  std::mt19937 rng{7};
  double step = 0.02, noise = 0.0;

  void plane(const Eigen::Vector3d& origin, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
    std::normal_distribution<double> jitter(0.0, noise);
    const int nu = static_cast<int>(u.norm() / step), nv = static_cast<int>(v.norm() / step);
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j) {
        Eigen::Vector3d p = origin + u * (double(i) / nu) + v * (double(j) / nv);
        if (noise > 0.0) p += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
        cloud.points.push_back(p.cast<float>());
        cloud.colours.push_back({128, 128, 128});
      }
  }
  void box(const Eigen::Vector3d& lo, const Eigen::Vector3d& size) {
    const Eigen::Vector3d x(size.x(), 0, 0), y(0, size.y(), 0), z(0, 0, size.z());
    plane(lo + z, x, y);  // top
    plane(lo, x, z);
    plane(lo + y, x, z);
    plane(lo, y, z);
    plane(lo + x, y, z);
  }
};

// A 6 x 4 m room, 2.5 m high, with furniture placed without symmetry. `seed` moves the
// furniture (another room).
render::PointCloud room(int seed, double step, double noise) {
  Sampler s;
  s.step = step;
  s.noise = noise;
  s.rng.seed(static_cast<unsigned>(seed));
  s.plane({0, 0, 0}, {6, 0, 0}, {0, 4, 0});    // floor
  s.plane({0, 0, 0}, {6, 0, 0}, {0, 0, 2.5});  // walls
  s.plane({0, 4, 0}, {6, 0, 0}, {0, 0, 2.5});
  s.plane({0, 0, 0}, {0, 4, 0}, {0, 0, 2.5});
  s.plane({6, 0, 0}, {0, 4, 0}, {0, 0, 2.5});
  std::mt19937 place(static_cast<unsigned>(seed));
  std::uniform_real_distribution<double> x(0.2, 5.0), y(0.2, 3.0), size(0.3, 1.0);
  for (int k = 0; k < 7; ++k)
    s.box({x(place), y(place), 0.0}, {size(place), size(place), size(place) + 0.2});
  return s.cloud;
}

// The part of `scan` with x < `keep_x` (what a walk through part of the room saw), moved into
// the map's frame.
render::PointCloud map_of(const render::PointCloud& scan, const SE3& map_from_scan, double keep_x) {
  render::PointCloud map;
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    if (scan.points[i].x() > keep_x) continue;
    map.points.push_back((map_from_scan * scan.points[i].cast<double>()).cast<float>());
    map.colours.push_back(scan.colours[i]);
  }
  return map;
}

// Coarser than the defaults (which are for rooms of a real site): the same search, in seconds.
GlobalRegistrationOptions test_options() {
  GlobalRegistrationOptions o;
  o.voxel_size = 0.08;
  o.icp_voxels = {0.08, 0.04};
  o.ransac_iterations = 4000;
  return o;
}

void expect_near(const SE3& a, const SE3& b, double metres, double degrees) {
  const SE3 d = a.inverse() * b;
  EXPECT_LT(d.translation().norm(), metres);
  EXPECT_LT(d.so3().log().norm() / kDeg, degrees);
}

TEST(GlobalRegistration, RecoversTheTransformFromAnyYaw) {
  const render::PointCloud scan = room(3, 0.03, 0.0);
  const render::PointCloud seen = room(3, 0.03, 0.004);  // the map's own noisy sampling
  for (const double yaw : {0.0, 100.0, 230.0}) {
    SCOPED_TRACE("yaw " + std::to_string(yaw));
    const SE3 map_from_scan(SO3::exp({0.0, 0.0, yaw * kDeg}), {-2.0, 7.5, 0.3});
    const render::PointCloud map = map_of(seen, map_from_scan, 4.5);
    GlobalRegistrationOptions o = test_options();
    o.gravity = yaw == 100.0;  // one run with the yaw-only search
    const GlobalRegistrationReport r = register_clouds(map, scan, o);
    std::cout << "yaw " << yaw << ": fitness " << r.fitness << ", RMSE " << r.rmse << " m, overlap "
              << r.overlap << ", runner-up " << r.runner_up << ", " << r.matches << " matches, "
              << r.ms << " ms\n";
    expect_near(r.scan_from_map, map_from_scan.inverse(), 0.02, 0.5);
    EXPECT_GT(r.fitness, 0.8);
    EXPECT_GT(r.overlap, 0.5);
    EXPECT_LT(r.runner_up, o.ambiguity * r.fitness);
  }
}

TEST(GlobalRegistration, AnInitialGuessIsRefinedWithoutTheSearch) {
  const render::PointCloud scan = room(3, 0.03, 0.0);
  const SE3 map_from_scan(SO3::exp({0.0, 0.0, 0.3}), {1.0, 2.0, 0.0});
  const render::PointCloud map = map_of(room(3, 0.03, 0.004), map_from_scan, 4.5);
  const SE3 guess = SE3(SO3::exp({0.0, 0.0, 0.05}), {0.08, -0.05, 0.02}) * map_from_scan.inverse();
  const GlobalRegistrationReport r = register_clouds(map, scan, test_options(), guess);
  EXPECT_TRUE(r.from_initial);
  expect_near(r.scan_from_map, map_from_scan.inverse(), 0.02, 0.5);
}

TEST(GlobalRegistration, ASymmetricCorridorIsAmbiguous) {
  // 12 m of bare corridor: any shift along it, and a half turn, fit as well as the truth.
  Sampler s;
  s.step = 0.03;
  s.plane({0, 0, 0}, {12, 0, 0}, {0, 2, 0});
  s.plane({0, 0, 0}, {12, 0, 0}, {0, 0, 2.5});
  s.plane({0, 2, 0}, {12, 0, 0}, {0, 0, 2.5});
  const render::PointCloud map = map_of(s.cloud, SE3(SO3(), {0.0, 0.0, 0.0}), 5.0);
  try {
    register_clouds(map, s.cloud, test_options());
    FAIL() << "a corridor must not register without a guess";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "registration") << e.what();
    std::cout << e.what() << "\n";
  }
}

TEST(GlobalRegistration, AMapOfAnotherRoomDoesNotFit) {
  const render::PointCloud scan = room(3, 0.03, 0.0);
  // Another room: the furniture elsewhere, and a map of its furniture only (no room shell, which
  // would fit any room of the same size).
  render::PointCloud other;
  const render::PointCloud elsewhere = room(11, 0.03, 0.004);
  for (std::size_t i = 0; i < elsewhere.points.size(); ++i) {
    const Eigen::Vector3f& p = elsewhere.points[i];
    if (p.z() > 0.05 && p.x() > 0.05 && p.x() < 5.95 && p.y() > 0.05 && p.y() < 3.95) {
      other.points.push_back(p);
      other.colours.push_back(elsewhere.colours[i]);
    }
  }
  try {
    register_clouds(other, scan, test_options());
    FAIL() << "furniture of another room must not register";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "registration") << e.what();
    std::cout << e.what() << "\n";
  }
}

// A bare 6 x 4 m room: the same shape turned half a turn about its centre. `posters` paints
// dark and bright rectangles on two walls (what hangs on real walls), which break the symmetry
// for the colours only.
render::PointCloud symmetric_room(bool posters) {
  Sampler s;
  s.step = 0.03;
  s.plane({0, 0, 0}, {6, 0, 0}, {0, 4, 0});
  s.plane({0, 0, 0}, {6, 0, 0}, {0, 0, 2.5});
  s.plane({0, 4, 0}, {6, 0, 0}, {0, 0, 2.5});
  s.plane({0, 0, 0}, {0, 4, 0}, {0, 0, 2.5});
  s.plane({6, 0, 0}, {0, 4, 0}, {0, 0, 2.5});
  if (posters) {
    for (std::size_t i = 0; i < s.cloud.points.size(); ++i) {
      const Eigen::Vector3f& p = s.cloud.points[i];
      const bool wall_y0 = std::abs(p.y()) < 1e-3f, wall_x0 = std::abs(p.x()) < 1e-3f;
      if (wall_y0 && p.x() > 0.8f && p.x() < 2.0f && p.z() > 0.9f && p.z() < 1.8f)
        s.cloud.colours[i] = {20, 20, 30};
      if (wall_y0 && p.x() > 3.5f && p.x() < 4.1f && p.z() > 1.2f && p.z() < 2.0f)
        s.cloud.colours[i] = {240, 230, 200};
      if (wall_x0 && p.y() > 0.5f && p.y() < 1.5f && p.z() > 0.5f && p.z() < 1.5f)
        s.cloud.colours[i] = {230, 40, 40};
    }
  }
  return s.cloud;
}

TEST(GlobalRegistration, ASymmetricRoomIsToldApartByWhatHangsOnItsWalls) {
  const render::PointCloud scan = symmetric_room(true);
  const SE3 map_from_scan(SO3::exp(Eigen::Vector3d(0, 0, 40 * kDeg)), {1.0, -2.0, 0.0});
  const render::PointCloud map = map_of(scan, map_from_scan, 10.0);
  GlobalRegistrationOptions o = test_options();
  o.gravity = true;
  const GlobalRegistrationReport r = register_clouds(map, scan, o);
  expect_near(r.scan_from_map, map_from_scan.inverse(), 0.03, 1.0);
  EXPECT_TRUE(r.decided_by_colour);  // the shape alone fits both ways
  EXPECT_GT(r.colour_correlation, 0.8);
  EXPECT_LT(r.runner_up_colour_correlation, r.colour_correlation - 0.2);
}

TEST(GlobalRegistration, ASymmetricGreyRoomIsAmbiguous) {
  const render::PointCloud scan = symmetric_room(false);
  const SE3 map_from_scan(SO3::exp(Eigen::Vector3d(0, 0, 40 * kDeg)), {1.0, -2.0, 0.0});
  GlobalRegistrationOptions o = test_options();
  o.gravity = true;
  try {
    register_clouds(map_of(scan, map_from_scan, 10.0), scan, o);
    FAIL() << "a grey symmetric room must not register without a guess";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "registration") << e.what();
    EXPECT_NE(std::string(e.what()).find("ambiguous"), std::string::npos) << e.what();
  }
}

TEST(GlobalRegistration, AFitWhoseColoursDisagreeIsRefused) {
  // The room's shape, but every colour inverted: the geometry fits, the place does not.
  const render::PointCloud scan = symmetric_room(true);
  render::PointCloud map = map_of(scan, SE3(SO3(), {0.5, 0.0, 0.0}), 10.0);
  for (auto& c : map.colours)
    c = {static_cast<std::uint8_t>(255 - c[0]), static_cast<std::uint8_t>(255 - c[1]),
         static_cast<std::uint8_t>(255 - c[2])};
  GlobalRegistrationOptions o = test_options();
  o.gravity = true;
  try {
    register_clouds(map, scan, o);
    FAIL() << "inverted colours must not register";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "registration") << e.what();
    EXPECT_NE(std::string(e.what()).find("the shape fits but the colours do not"),
              std::string::npos)
        << e.what();
  }
}

TEST(GlobalRegistration, OptionsAreChecked) {
  GlobalRegistrationOptions o;
  o.voxel_size = 0.0;
  EXPECT_THROW(o.check(), Error);
  o = {};
  o.icp_voxels.clear();
  EXPECT_THROW(o.check(), Error);
  o = {};
  o.ransac_iterations = -1;
  EXPECT_THROW(o.check(), Error);
  o.ransac_iterations = 0;  // by the sample size
  o.threads = -1;
  EXPECT_THROW(o.check(), Error);
  o.threads = 0;  // one per core
  EXPECT_NO_THROW(o.check());
}

}  // namespace
}  // namespace coloc::registration::align
