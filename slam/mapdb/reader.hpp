#pragma once
// Opening a map file for reading and walking its tables with their checks (internal to
// slam/mapdb): load_map(), verify_map(), read_map_info() and the exports share it.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "slam/mapdb/metadata.hpp"
#include "slam/mapdb/sqlite.hpp"

namespace coloc::slam::mapdb::detail {

// A map file opened read-only whose header was checked: application id, schema version not
// newer than ours, every table of that version present; its metadata entries are read.
class MapFile {
 public:
  MapFile(const std::filesystem::path& path, int cache_mib);

  Database& db() { return db_; }
  const std::filesystem::path& path() const { return path_; }
  int schema_version() const { return schema_version_; }
  const MetadataEntries& entries() const { return entries_; }
  MapCounts counts() const;
  // Throws naming the file, "table.column" and the row.
  [[noreturn]] void fail(const std::string& field, const std::string& row,
                         const std::string& message) const;

 private:
  std::filesystem::path path_;
  Database db_;
  int schema_version_ = 0;
  MetadataEntries entries_;
};

// A full read of one table in key order that also checks, at its end, the row count and the
// content checksum the metadata states for it.
class TableReader {
 public:
  TableReader(MapFile& file, const std::string& table);
  bool next();
  Statement& row() { return stmt_; }
  // Column c as an id: NULL is the invalid id when `nullable`, an error otherwise; a negative
  // value is an error. `column` names it in errors.
  std::uint64_t id(int c, const std::string& column, const std::string& row, bool nullable,
                   bool* valid = nullptr);
  [[noreturn]] void fail(const std::string& column, const std::string& row,
                         const std::string& message) const;
  const std::string& table() const { return table_; }

 private:
  std::string last_key() const;
  void finish();
  MapFile& file_;
  std::string table_;
  Statement stmt_;
  ContentHash hash_;
  std::uint64_t rows_ = 0;
  bool done_ = false;
  int key_columns_ = 1;
  // Key of the last row read (integer columns), to place an error SQLite reports mid-table.
  std::int64_t last_key_[2] = {0, 0};
};

// SQLite's own check of its page structure (PRAGMA integrity_check), table by table so that
// each problem names its table, then over the whole file (pages that belong to no table).
std::vector<std::string> integrity_problems(const std::filesystem::path& path);

}  // namespace coloc::slam::mapdb::detail
