#include "slam/mapdb/schema.hpp"

#include "slam/core/error.hpp"

namespace coloc::slam::mapdb::detail {

// Ids are SQLite INTEGERs (signed 64-bit): our ids are issued from 0 upwards, and an invalid id
// (a keyframe without parent) is NULL. REAL columns hold IEEE doubles exactly; a NaN is NULL.
const std::vector<TableSchema>& tables() {
  static const std::vector<TableSchema> kTables = {
      {"metadata", "key, value", "key",
       "CREATE TABLE metadata (key TEXT PRIMARY KEY NOT NULL, value TEXT NOT NULL) "
       "WITHOUT ROWID",
       1},
      {"cameras",
       "id, model, width, height, fx, fy, cx, cy, distortion, bf, close_depth, min_depth, "
       "max_depth, readout, min_x, max_x, min_y, max_y, grid_cols, grid_rows, scale_factors",
       "id",
       "CREATE TABLE cameras (id INTEGER PRIMARY KEY, model TEXT NOT NULL, width INTEGER NOT "
       "NULL, height INTEGER NOT NULL, fx REAL, fy REAL, cx REAL, cy REAL, distortion BLOB NOT "
       "NULL, bf REAL, close_depth REAL, min_depth REAL, max_depth REAL, readout REAL, min_x "
       "REAL, max_x REAL, min_y REAL, max_y REAL, grid_cols INTEGER NOT NULL, grid_rows INTEGER "
       "NOT NULL, scale_factors BLOB NOT NULL)",
       1},
      {"keyframes",
       "id, frame_id, timestamp, camera_id, tx, ty, tz, qx, qy, qz, qw, cam_from_world, "
       "has_pose, parent, image_width, image_height, keypoint_count, marker_size",
       "id",
       "CREATE TABLE keyframes (id INTEGER PRIMARY KEY, frame_id INTEGER, timestamp "
       "REAL, camera_id INTEGER NOT NULL, tx REAL, ty REAL, tz REAL, qx REAL, qy REAL, qz REAL, "
       "qw REAL, cam_from_world BLOB NOT NULL, has_pose INTEGER NOT NULL, parent INTEGER, "
       "image_width INTEGER NOT NULL, image_height INTEGER NOT NULL, keypoint_count INTEGER NOT "
       "NULL, marker_size REAL)",
       1},
      {"keyframe_features", "keyframe_id, keypoints, descriptors, checksum", "keyframe_id",
       "CREATE TABLE keyframe_features (keyframe_id INTEGER PRIMARY KEY, keypoints BLOB NOT "
       "NULL, descriptors BLOB NOT NULL, checksum INTEGER NOT NULL)",
       1},
      {"markers",
       "keyframe_id, seq, marker_id, x0, y0, x1, y1, x2, y2, x3, y3, image_width, image_height",
       "keyframe_id, seq",
       "CREATE TABLE markers (keyframe_id INTEGER NOT NULL, seq INTEGER NOT NULL, marker_id "
       "INTEGER NOT NULL, x0 REAL, y0 REAL, x1 REAL, y1 REAL, x2 REAL, y2 REAL, x3 REAL, y3 "
       "REAL, image_width INTEGER NOT NULL, image_height INTEGER NOT NULL, PRIMARY KEY "
       "(keyframe_id, seq)) WITHOUT ROWID",
       1},
      {"map_points",
       "id, x, y, z, descriptor, nx, ny, nz, min_distance, max_distance, reference_keyframe, "
       "first_keyframe, visible, found",
       "id",
       "CREATE TABLE map_points (id INTEGER PRIMARY KEY, x REAL, y REAL, z REAL, descriptor "
       "BLOB NOT NULL, nx REAL, ny REAL, nz REAL, min_distance REAL, max_distance REAL, "
       "reference_keyframe INTEGER, first_keyframe INTEGER, visible INTEGER NOT NULL, found "
       "INTEGER NOT NULL)",
       1},
      {"observations", "keyframe_id, keypoint, point_id", "keyframe_id, keypoint",
       "CREATE TABLE observations (keyframe_id INTEGER NOT NULL, keypoint INTEGER NOT NULL, "
       "point_id INTEGER NOT NULL, PRIMARY KEY (keyframe_id, keypoint)) WITHOUT ROWID",
       1},
      {"covisibility", "keyframe_id, other_id, weight", "keyframe_id, other_id",
       "CREATE TABLE covisibility (keyframe_id INTEGER NOT NULL, other_id INTEGER NOT NULL, "
       "weight INTEGER NOT NULL, PRIMARY KEY (keyframe_id, other_id)) WITHOUT ROWID",
       1},
      {"loop_edges", "keyframe_id, other_id", "keyframe_id, other_id",
       "CREATE TABLE loop_edges (keyframe_id INTEGER NOT NULL, other_id INTEGER NOT NULL, "
       "PRIMARY KEY (keyframe_id, other_id)) WITHOUT ROWID",
       2},
      {"gravity_windows", "keyframe_id, recording, fx, fy, fz, ax, ay, az", "keyframe_id",
       "CREATE TABLE gravity_windows (keyframe_id INTEGER PRIMARY KEY, recording INTEGER NOT "
       "NULL, fx REAL, fy REAL, fz REAL, ax REAL, ay REAL, az REAL)",
       3},
      {"gyro_links", "keyframe_id, recording, next_id, qx, qy, qz, qw, bias_jacobian, dt",
       "keyframe_id",
       "CREATE TABLE gyro_links (keyframe_id INTEGER PRIMARY KEY, recording INTEGER NOT NULL, "
       "next_id INTEGER NOT NULL, qx REAL, qy REAL, qz REAL, qw REAL, bias_jacobian BLOB NOT "
       "NULL, dt REAL)",
       3},
      {"keyframe_depth", "keyframe_id, width, height, factor, depth, checksum", "keyframe_id",
       "CREATE TABLE keyframe_depth (keyframe_id INTEGER PRIMARY KEY, width INTEGER NOT NULL, "
       "height INTEGER NOT NULL, factor INTEGER NOT NULL, depth BLOB NOT NULL, checksum INTEGER "
       "NOT NULL)",
       4},
      {"erased_keyframes", "id, parent, cam_from_parent", "id",
       "CREATE TABLE erased_keyframes (id INTEGER PRIMARY KEY, parent INTEGER NOT NULL, "
       "cam_from_parent BLOB NOT NULL)",
       1},
  };
  return kTables;
}

const TableSchema& table(const std::string& name) {
  for (const TableSchema& t : tables()) {
    if (name == t.name) return t;
  }
  throw Error("map database: no table '" + name + "' in the schema");
}

bool has_table(int version, const std::string& name) {
  return version >= table(name).since;
}

std::string insert_sql(const TableSchema& t) {
  std::string marks = "?";
  for (const char* c = t.columns; *c; ++c) {
    if (*c == ',') marks += ", ?";
  }
  return std::string("INSERT INTO ") + t.name + " (" + t.columns + ") VALUES (" + marks + ")";
}

std::string select_sql(const TableSchema& t) {
  return std::string("SELECT ") + t.columns + " FROM " + t.name + " ORDER BY " + t.key;
}

}  // namespace coloc::slam::mapdb::detail
