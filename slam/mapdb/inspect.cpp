// Reading parts of a map file without loading the map: info, keyframe trajectory, points.
#include <algorithm>

#include "slam/core/error.hpp"
#include "slam/mapdb/codec.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/reader.hpp"
#include "slam/mapdb/schema.hpp"

namespace coloc::slam::mapdb {

namespace fs = std::filesystem;
using detail::MapFile;
using detail::Statement;

namespace {

constexpr int kCacheMib = 8;

}  // namespace

MapInfo read_map_info(const fs::path& path) {
  MapFile file(path, kCacheMib);
  MapInfo info;
  info.schema_version = file.schema_version();
  info.metadata = detail::parse_metadata(file.entries(), path);
  info.counts = file.counts();
  info.file_bytes = fs::file_size(path);
  // The camera model is in the first `cameras` row (metadata holds no copy of it).
  Statement s(file.db(), "SELECT model, width, height, fx, fy, cx, cy FROM cameras ORDER BY id",
              "cameras");
  if (s.next() && s.column_text(0) != "none") {
    PinholeCamera c;
    c.width = static_cast<int>(s.column_integer(1));
    c.height = static_cast<int>(s.column_integer(2));
    c.fx = s.column_real(3);
    c.fy = s.column_real(4);
    c.cx = s.column_real(5);
    c.cy = s.column_real(6);
    if (s.column_text(0) == "PinHole") {
      info.metadata.camera = c;
    } else {
      info.metadata.camera = KannalaBrandtCamera{c.width, c.height, c.fx, c.fy, c.cx, c.cy, {}};
    }
  }
  return info;
}

Trajectory read_keyframe_trajectory(const fs::path& path) {
  MapFile file(path, kCacheMib);
  Statement s(file.db(), "SELECT id, timestamp, cam_from_world FROM keyframes ORDER BY id",
              "keyframes");
  Trajectory out;
  while (s.next()) {
    if (s.column_blob(2).size() != detail::kPoseBytes)
      file.fail("keyframes.cam_from_world", std::to_string(s.column_integer(0)), "not 56 bytes");
    out.push_back({s.column_real(1), detail::decode_pose(s.column_blob(2)).inverse()});
  }
  // Keyframe ids follow time; a stable sort by timestamp keeps that order for equal stamps.
  std::stable_sort(out.begin(), out.end(), [](const StampedPose& a, const StampedPose& b) {
    return a.timestamp < b.timestamp;
  });
  return out;
}

void for_each_point(const fs::path& path, const std::function<void(const PointRecord&)>& visit) {
  MapFile file(path, kCacheMib);
  // Observation counts per point by one grouped scan (observations are keyed by keyframe).
  Statement s(file.db(),
              "SELECT p.id, p.x, p.y, p.z, p.nx, p.ny, p.nz, COALESCE(c.n, 0) FROM map_points p "
              "LEFT JOIN (SELECT point_id, COUNT(*) AS n FROM observations GROUP BY point_id) c "
              "ON c.point_id = p.id ORDER BY p.id",
              "map_points");
  PointRecord r;
  while (s.next()) {
    r.id = MapPointId(static_cast<std::uint64_t>(s.column_integer(0)));
    r.position = {s.column_real(1), s.column_real(2), s.column_real(3)};
    r.normal = {s.column_real(4), s.column_real(5), s.column_real(6)};
    r.observations = static_cast<std::uint32_t>(s.column_integer(7));
    visit(r);
  }
}

}  // namespace coloc::slam::mapdb
