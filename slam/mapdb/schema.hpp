#pragma once
// The map file's schema, version 4 (internal to slam/mapdb; documented in docs/formats/mapdb.md).
// Version 2 added `loop_edges`, version 3 `gravity_windows` and `gyro_links`, version 4
// `keyframe_depth`; an older file has every other table. Every
// table is written and read with its columns in the order listed here: INSERT binds and SELECT
// reads them in that order, which is also the order the content checksums hash them in.
#include <cstdint>
#include <string>
#include <vector>

namespace coloc::slam::mapdb::detail {

// PRAGMA application_id: "CLCM" (coloc map), so `file` and our loader can tell our maps from
// any other SQLite database.
constexpr std::int32_t kApplicationId = 0x434c434d;

struct TableSchema {
  const char* name;
  const char* columns;  // comma-separated, in binding order
  const char* key;      // ORDER BY of a full read (the primary key)
  const char* create;   // CREATE TABLE statement
  int since;            // the schema version that added the table (older files lack it)
};

// Every table of the schema (metadata first), in the order a save creates them.
const std::vector<TableSchema>& tables();
// Whether a file of schema version `version` has table `name`.
bool has_table(int version, const std::string& name);
const TableSchema& table(const std::string& name);

// "INSERT INTO t (columns) VALUES (?, ...)" and "SELECT columns FROM t ORDER BY key".
std::string insert_sql(const TableSchema& t);
std::string select_sql(const TableSchema& t);

// Record sizes of the blobs (bytes, little-endian; layouts in codec.hpp).
constexpr std::size_t kKeypointRecordBytes = 36;
constexpr std::size_t kDescriptorBytes = 32;
constexpr std::size_t kPoseBytes = 56;
constexpr std::size_t kBiasJacobianBytes = 72;  // 3 x 3 f64, row-major
constexpr std::size_t kDepthPixelBytes = 2;     // u16 millimetres per pixel of keyframe_depth

}  // namespace coloc::slam::mapdb::detail
