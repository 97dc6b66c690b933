// The scan's voxel grid built while the file is read (voxel_grid.hpp): the same cloud as the
// batch voxel_downsample over every point (positions, colours, splats, order), whatever the
// piece size; the finest-stations rule when stations arrive far to near, including the voxels
// that need the second reading; voxel size 0; damaged files named.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "e57io/writer.hpp"
#include "registration/align/scan_cloud.hpp"
#include "registration/align/voxel_grid.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {
namespace {

namespace fs = std::filesystem;
using e57::field_bit;
using F = e57::PointField;

fs::path temp(const std::string& name) {
  return fs::path(::testing::TempDir()) / ("scan_stream_" + name);
}

struct Station {
  Eigen::Vector3d position;
  double yaw = 0.0;                    // radians about z
  std::vector<Eigen::Vector3d> world;  // points, file frame
  std::array<std::uint8_t, 3> rgb{};   // colour of every point; zero: coloured by position
};

// One data3D per station, points in the station's frame (world_from_scan as the pose).
void write_stations(const fs::path& path, const std::vector<Station>& stations) {
  e57::Writer w(path);
  for (const Station& st : stations) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(st.yaw, Eigen::Vector3d::UnitZ()));
    e57::Data3D h;
    h.name = "station";
    h.pose = e57::Pose{{q.w(), q.x(), q.y(), q.z()},
                       {st.position.x(), st.position.y(), st.position.z()}};
    e57::PointBuffer b;
    b.reset(field_bit(F::kCartesianX) | field_bit(F::kCartesianY) | field_bit(F::kCartesianZ) |
                field_bit(F::kColorRed) | field_bit(F::kColorGreen) | field_bit(F::kColorBlue),
            st.world.size());
    for (std::size_t i = 0; i < st.world.size(); ++i) {
      const Eigen::Vector3d& p = st.world[i];
      const Eigen::Vector3d local = q.inverse() * (p - st.position);
      b.cartesian_x[i] = local.x();
      b.cartesian_y[i] = local.y();
      b.cartesian_z[i] = local.z();
      const bool own = st.rgb != std::array<std::uint8_t, 3>{};
      b.color_red[i] =
          own ? st.rgb[0]
              : std::floor(static_cast<float>(std::fmod(std::abs(p.x()) * 97.0, 255.0)));
      b.color_green[i] =
          own ? st.rgb[1]
              : std::floor(static_cast<float>(std::fmod(std::abs(p.y()) * 61.0, 255.0)));
      b.color_blue[i] =
          own ? st.rgb[2]
              : std::floor(static_cast<float>(std::fmod(std::abs(p.z()) * 89.0, 255.0)));
    }
    w.write_scan(h,
                 {e57::FieldSpec::scaled(F::kCartesianX, 1e-4, -50, 50),
                  e57::FieldSpec::scaled(F::kCartesianY, 1e-4, -50, 50),
                  e57::FieldSpec::scaled(F::kCartesianZ, 1e-4, -50, 50),
                  e57::FieldSpec::integer(F::kColorRed, 0, 255),
                  e57::FieldSpec::integer(F::kColorGreen, 0, 255),
                  e57::FieldSpec::integer(F::kColorBlue, 0, 255)},
                 b);
  }
  w.close();
}

// A station inside a 4 x 3 x 2.5 m room, sampling its walls on a full-sphere angular grid.
Station room_station(const Eigen::Vector3d& at, double yaw) {
  Station st{.position = at, .yaw = yaw, .world = {}, .rgb = {}};
  const Eigen::Vector3d lo(0, 0, 0), hi(4, 3, 2.5);
  for (int e = 0; e < 90; ++e) {
    const double el = -1.5 + 3.0 * (e + 0.5) / 90.0;
    for (int a = 0; a < 180; ++a) {
      const double az = 2.0 * std::numbers::pi * a / 180.0 + yaw;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
      double t = 1e9;
      for (int k = 0; k < 3; ++k) {
        if (d[k] > 1e-12) t = std::min(t, (hi[k] - at[k]) / d[k]);
        if (d[k] < -1e-12) t = std::min(t, (lo[k] - at[k]) / d[k]);
      }
      st.world.push_back(at + t * d);
    }
  }
  return st;
}

// The batch form: every point in memory, then voxel_downsample and the stray filter.
render::PointCloud batch_load(const fs::path& path, const ScanCloudOptions& o) {
  render::PointCloud all;
  read_scan_pieces(path, o, [&](const ScanPiece& piece) {
    all.points.insert(all.points.end(), piece.points.begin(), piece.points.end());
    all.colours.insert(all.colours.end(), piece.colours.begin(), piece.colours.end());
    all.splat_sizes.insert(all.splat_sizes.end(), piece.spacings.begin(), piece.spacings.end());
  });
  render::PointCloud out = voxel_downsample(all, o);
  remove_stray_points(out, o.stray);
  return out;
}

void expect_same(const render::PointCloud& a, const render::PointCloud& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  ASSERT_EQ(a.splat_sizes.size(), b.splat_sizes.size());
  EXPECT_EQ(a.splat_size, b.splat_size);
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    ASSERT_LE((a.points[i] - b.points[i]).cwiseAbs().maxCoeff(), 1e-6f) << "voxel " << i;
    ASSERT_EQ(a.colours[i], b.colours[i]) << "voxel " << i;
    if (!a.splat_sizes.empty()) {
      ASSERT_NEAR(a.splat_sizes[i], b.splat_sizes[i], 1e-6f * a.splat_sizes[i]);
    }
  }
}

TEST(ScanStream, EqualsTheBatchGridForEveryPieceSize) {
  const fs::path file = temp("room.e57");
  write_stations(file, {room_station({3.5, 2.5, 1.5}, 0.3), room_station({2.0, 1.5, 1.2}, 1.1),
                        room_station({0.5, 0.4, 0.6}, 2.0), room_station({1.0, 2.6, 2.2}, 0.0)});
  ScanCloudOptions o;
  o.voxel_size = 0.2;
  // The grid itself must meet voxels whose stations arrive far to near, or the second reading
  // goes untested here.
  VoxelGrid grid(o.voxel_size, true);
  read_scan_pieces(file, o, [&](const ScanPiece& piece) {
    for (std::size_t i = 0; i < piece.points.size(); ++i)
      grid.add(piece.points[i], piece.colours[i], piece.spacings[i]);
  });
  EXPECT_GT(grid.ambiguous(), 0u);
  const render::PointCloud batch = batch_load(file, o);
  ASSERT_GT(batch.points.size(), 100u);
  for (const std::size_t chunk : {std::size_t{1}, std::size_t{7}, std::size_t{1} << 16}) {
    SCOPED_TRACE(chunk);
    o.chunk_points = chunk;
    ScanCloudStats stats;
    std::uint64_t last = 0;
    const render::PointCloud streamed =
        load_scan_cloud(file, o, &stats, [&](std::uint64_t done, std::uint64_t) { last = done; });
    EXPECT_EQ(stats.scans, 4u);
    EXPECT_EQ(stats.points_read, 4u * 90 * 180);
    EXPECT_EQ(last, stats.points_read);
    EXPECT_EQ(stats.points_kept, streamed.points.size());
    EXPECT_TRUE(stats.colour);
    expect_same(streamed, batch);
  }
  o.range_splat_factor = 0.0;  // no spacing: every point of a voxel, one splat size
  const render::PointCloud plain = load_scan_cloud(file, o);
  EXPECT_TRUE(plain.splat_sizes.empty());
  expect_same(plain, batch_load(file, o));
  fs::remove(file);
}

// Three stations see one voxel, far to near: spacings 3, 2.5 and 1.8 (ranges, the same angular
// step). The near one keeps the middle one (2.5 <= 1.5 x 1.8) and drops the far one, which the
// grid learns only after summing the far and middle together: the second reading sorts it out.
TEST(ScanStream, FinestStationsFromFarToNear) {
  const Eigen::Vector3d voxel(1.05, 0.05, 0.05);
  const auto patch = [&](const Eigen::Vector3d& from, std::array<std::uint8_t, 3> rgb) {
    Station st{.position = from, .yaw = 0.0, .world = {}, .rgb = rgb};
    for (int i = 0; i < 4; ++i)
      st.world.push_back(voxel + Eigen::Vector3d(0.01 * i, -0.02 + 0.01 * i, 0.03));
    return st;
  };
  const fs::path file = temp("far_to_near.e57");
  write_stations(file, {patch(voxel + Eigen::Vector3d(3, 0, 0), {255, 0, 0}),
                        patch(voxel + Eigen::Vector3d(0, 2.5, 0), {0, 255, 0}),
                        patch(voxel + Eigen::Vector3d(0, 0, 1.8), {0, 0, 255})});
  ScanCloudOptions o;
  o.voxel_size = 0.1;
  o.stray.min_neighbours = 0;  // one voxel alone is no stray here
  for (const std::size_t chunk : {std::size_t{1}, std::size_t{7}}) {
    o.chunk_points = chunk;
    const render::PointCloud c = load_scan_cloud(file, o);
    ASSERT_EQ(c.points.size(), 1u);
    EXPECT_EQ(c.colours[0], (std::array<std::uint8_t, 3>{0, 128, 128}));
    expect_same(c, batch_load(file, o));
  }
  fs::remove(file);

  // The same on the grid alone, and near to far, where no voxel needs a second reading.
  const std::array<std::uint8_t, 3> red{255, 0, 0}, green{0, 255, 0}, blue{0, 0, 255};
  const Eigen::Vector3f p = voxel.cast<float>();
  VoxelGrid far_first(0.1, true);
  far_first.add(p, red, 3.0f);
  far_first.add(p, green, 2.5f);
  far_first.add(p, blue, 1.8f);
  EXPECT_EQ(far_first.ambiguous(), 1u);
  far_first.begin_second_pass();
  far_first.add(p, red, 3.0f);
  far_first.add(p, green, 2.5f);
  far_first.add(p, blue, 1.8f);
  const render::PointCloud a = far_first.take_means();
  ASSERT_EQ(a.points.size(), 1u);
  EXPECT_EQ(a.colours[0], (std::array<std::uint8_t, 3>{0, 128, 128}));
  EXPECT_FLOAT_EQ(a.splat_sizes[0], 2.15f);  // the mean spacing of the kept points
  VoxelGrid near_first(0.1, true);
  near_first.add(p, blue, 1.8f);
  near_first.add(p, green, 2.5f);
  near_first.add(p, red, 3.0f);
  EXPECT_EQ(near_first.ambiguous(), 0u);
  EXPECT_EQ(near_first.take_means().colours[0], a.colours[0]);
  // A station 10x finer replaces what a coarse one summed, without a second reading.
  VoxelGrid replaced(0.1, true);
  replaced.add(p, red, 10.0f);
  replaced.add(p, red, 11.0f);
  replaced.add(p, blue, 1.0f);
  EXPECT_EQ(replaced.ambiguous(), 0u);
  EXPECT_EQ(replaced.take_means().colours[0], blue);
}

TEST(ScanStream, VoxelSizeZeroKeepsEveryPoint) {
  const fs::path file = temp("zero.e57");
  write_stations(file, {room_station({2.0, 1.5, 1.2}, 0.0)});
  ScanCloudOptions o;
  o.voxel_size = 0.0;
  o.stray.min_neighbours = 0;
  o.chunk_points = 7;
  ScanCloudStats stats;
  const render::PointCloud c = load_scan_cloud(file, o, &stats);
  EXPECT_EQ(c.points.size(), 90u * 180);
  EXPECT_EQ(stats.points_kept, 90u * 180);
  expect_same(c, batch_load(file, o));
  fs::remove(file);
}

TEST(ScanStream, DamagedFilesAreNamed) {
  const fs::path file = temp("cut.e57");
  write_stations(file, {room_station({2.0, 1.5, 1.2}, 0.0)});
  fs::resize_file(file, fs::file_size(file) / 2);
  const auto file_of_error = [](const fs::path& path, const ScanCloudOptions& o) {
    try {
      load_scan_cloud(path, o);
    } catch (const Error& e) {
      return e.context().file;
    }
    return std::string("no error");
  };
  EXPECT_EQ(file_of_error(file, {}), file.string());
  const fs::path junk = temp("junk.e57");
  std::ofstream(junk, std::ios::binary) << "ASTM-E57 but not really";
  EXPECT_EQ(file_of_error(junk, {}), junk.string());
  EXPECT_EQ(file_of_error(temp("absent.e57"), {}), temp("absent.e57").string());
  ScanCloudOptions o;
  o.chunk_points = 0;
  try {
    o.check();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "chunk_points");
  }
  fs::remove(file);
  fs::remove(junk);
}

}  // namespace
}  // namespace coloc::registration::align
