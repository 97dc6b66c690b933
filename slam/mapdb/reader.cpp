#include "slam/mapdb/reader.hpp"

#include <algorithm>
#include <set>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/mapdb/schema.hpp"

namespace coloc::slam::mapdb::detail {

namespace fs = std::filesystem;

namespace {

Database open_read_only(const fs::path& path) {
  check_input_file(path, "map file");  // says what the path is: missing, a FIFO, a directory
  return Database(path, Database::Mode::kReadOnly);
}

}  // namespace

MapFile::MapFile(const fs::path& path, int cache_mib) : path_(path), db_(open_read_only(path)) {
  // The first statements make SQLite read the file header and its schema (sqlite_master): a
  // file damaged there fails here.
  db_.exec("PRAGMA cache_size = -" + std::to_string(cache_mib * 1024), "sqlite_master");
  const std::int64_t version = db_.query_integer("PRAGMA user_version", "user_version");
  if (version > kSchemaVersion)
    fail("user_version", "",
         "schema version " + std::to_string(version) + " is newer than this build reads (" +
             std::to_string(kSchemaVersion) + "): use a newer coloc");
  const bool ours = db_.query_integer("PRAGMA application_id", "application_id") == kApplicationId;
  std::set<std::string> present;
  Statement names(db_, "SELECT name FROM sqlite_master WHERE type = 'table'", "sqlite_master");
  while (names.next())
    present.insert(names.column_text(0));
  for (const TableSchema& t : tables()) {
    // A table newer than the file's version is absent (and not read); one it should have is not.
    if (!present.count(t.name) && has_table(std::max(static_cast<int>(version), 1), t.name))
      fail(t.name, "",
           std::string("table '") + t.name + "' is missing" +
               (ours ? "" : " (not a coloc map: wrong or no application_id)"));
  }
  if (!ours) fail("application_id", "", "not a coloc map (wrong application_id)");
  if (version < 1) fail("user_version", "", "schema version " + std::to_string(version));
  schema_version_ = static_cast<int>(version);
  Statement meta(db_, select_sql(table("metadata")), "metadata");
  while (meta.next())
    entries_[meta.column_text(0)] = meta.column_text(1);
  const std::uint64_t stored = entry_hex64(entries_, "checksum.metadata", path_);
  if (stored != metadata_checksum(entries_))
    fail("metadata", "", "content checksum mismatch: the file is damaged or was edited");
}

void MapFile::fail(const std::string& field, const std::string& row,
                   const std::string& message) const {
  throw Error(row.empty() ? message : "row " + row + ": " + message,
              {.file = path_.string(), .field = field});
}

MapCounts MapFile::counts() const {
  const auto n = [&](const char* t) {
    return entry_u64(entries_, std::string("count.") + t, path_);
  };
  MapCounts c;
  c.keyframes = n("keyframes");
  c.points = n("map_points");
  c.observations = n("observations");
  c.markers = n("markers");
  c.covisibility = n("covisibility");
  c.erased_keyframes = n("erased_keyframes");
  c.cameras = n("cameras");
  if (has_table(schema_version_, "loop_edges")) c.loop_edges = n("loop_edges");
  if (has_table(schema_version_, "gravity_windows")) c.gravity_windows = n("gravity_windows");
  if (has_table(schema_version_, "gyro_links")) c.gyro_links = n("gyro_links");
  if (has_table(schema_version_, "keyframe_depth")) c.keyframe_depths = n("keyframe_depth");
  return c;
}

TableReader::TableReader(MapFile& file, const std::string& table_name)
    : file_(file),
      table_(table_name),
      stmt_(file.db(), select_sql(detail::table(table_name)), table_name),
      key_columns_(std::string(detail::table(table_name).key).find(',') == std::string::npos ? 1
                                                                                             : 2) {}

std::string TableReader::last_key() const {
  if (key_columns_ == 1) return std::to_string(last_key_[0]);
  std::string key = "(";  // appended, not operator+: GCC 12 false -Wrestrict (bug 105329)
  key += std::to_string(last_key_[0]);
  key += ", ";
  key += std::to_string(last_key_[1]);
  key += ')';
  return key;
}

bool TableReader::next() {
  if (done_) return false;
  bool row = false;
  try {
    row = stmt_.next();
  } catch (const Error& e) {
    // SQLite names no row; the last good one tells where in the table the damage starts.
    fail("", rows_ == 0 ? "" : "after " + last_key(), e.message());
  }
  if (row) {
    hash_.fold(stmt_.row_hash());
    ++rows_;
    for (int c = 0; c < key_columns_; ++c)
      last_key_[c] = stmt_.column_integer(c);
    return true;
  }
  done_ = true;
  finish();
  return false;
}

void TableReader::finish() {
  const MetadataEntries& e = file_.entries();
  const std::uint64_t expected = entry_u64(e, "count." + table_, file_.path());
  if (rows_ != expected)
    fail("", "",
         std::to_string(rows_) + " rows where the metadata says " + std::to_string(expected) +
             ": the file is truncated or damaged");
  if (hash_.value() != entry_hex64(e, "checksum." + table_, file_.path()))
    fail("", "", "content checksum mismatch: the file is damaged or was edited");
}

std::uint64_t TableReader::id(int c, const std::string& column, const std::string& row,
                              bool nullable, bool* valid) {
  if (valid) *valid = !stmt_.is_null(c);
  if (stmt_.is_null(c)) {
    if (!nullable) fail(column, row, "NULL where an id is required");
    return ~0ULL;
  }
  const std::int64_t v = stmt_.column_integer(c);
  if (v < 0) fail(column, row, "negative id " + std::to_string(v));
  return static_cast<std::uint64_t>(v);
}

void TableReader::fail(const std::string& column, const std::string& row,
                       const std::string& message) const {
  file_.fail(column.empty() ? table_ : table_ + "." + column, row, message);
}

}  // namespace coloc::slam::mapdb::detail

namespace coloc::slam::mapdb::detail {

std::vector<std::string> integrity_problems(const fs::path& path) {
  std::vector<std::string> problems;
  Database db(path, Database::Mode::kReadOnly);
  auto check = [&](const std::string& pragma, const std::string& table) {
    const std::string where = path.string() + ": " + (table.empty() ? "" : "table " + table + ": ");
    try {
      Statement s(db, pragma, table.empty() ? "integrity_check" : table);
      while (s.next()) {
        const std::string line = s.column_text(0);
        if (line == "ok") continue;
        std::string problem = where;
        problem += "integrity_check: ";
        problem += line;
        problems.push_back(std::move(problem));
      }
    } catch (const Error& e) {
      problems.push_back(where + "integrity_check: " + e.message());
    }
  };
  // Tables a file of an older schema version lacks are skipped (MapFile checks the presence).
  std::set<std::string> present;
  try {
    Statement names(db, "SELECT name FROM sqlite_master WHERE type = 'table'", "sqlite_master");
    while (names.next())
      present.insert(names.column_text(0));
  } catch (const Error& e) {
    problems.push_back(path.string() + ": table sqlite_master: " + e.message());
  }
  for (const TableSchema& t : tables()) {
    if (present.count(t.name)) check(std::string("PRAGMA integrity_check(") + t.name + ")", t.name);
  }
  if (problems.empty()) check("PRAGMA integrity_check", "");
  return problems;
}

}  // namespace coloc::slam::mapdb::detail
