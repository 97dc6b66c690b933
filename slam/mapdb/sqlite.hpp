#pragma once
// A thin RAII layer over the SQLite C API for the map database (internal to slam/mapdb): a
// connection, prepared statements with sequential binding, and every failure turned into a
// coloc::Error naming the file and the table being read or written.
//
// ContentHash is the checksum the map file stores per table (README "Map database"): SQLite
// checks its own page structure, not the bytes of a blob or a REAL, so a flipped bit inside a
// descriptor would otherwise load silently.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

struct sqlite3;
struct sqlite3_stmt;

namespace coloc::slam::mapdb::detail {

// 64-bit hash of a sequence of typed values. Each step h = mix(h ^ w) is a bijection in h and
// in w, so changing any single 64-bit word of the input always changes the result.
class ContentHash {
 public:
  void integer(std::int64_t v);
  // NaN hashes as null and -0.0 as 0.0: SQLite stores a NaN REAL as NULL and an integral one
  // as an integer, and the loader must agree with what was bound.
  void real(double v);
  void text(std::string_view v);
  void blob(std::span<const std::uint8_t> v);
  void null();
  // Folds another hash in (a row's hash into its table's).
  void fold(std::uint64_t v) { word(v); }
  std::uint64_t value() const { return h_; }

 private:
  void word(std::uint64_t w);
  void bytes(std::uint64_t tag, const std::uint8_t* data, std::size_t size);
  std::uint64_t h_ = 0x636f6c6f632d6d61ULL;  // "coloc-ma"
};

class Database {
 public:
  enum class Mode { kCreate, kReadOnly };
  // kCreate opens (creating) a file for writing; kReadOnly never creates or writes anything.
  Database(const std::filesystem::path& path, Mode mode);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Runs SQL without results; errors name `table` (or "" for statements about no table).
  void exec(const std::string& sql, std::string_view table = {});
  // The single integer a query such as "PRAGMA user_version" returns.
  std::int64_t query_integer(const std::string& sql, std::string_view table = {});
  // Closes the connection; throws if SQLite reports an error (a last write that failed).
  void close();
  [[noreturn]] void fail(int rc, std::string_view what, std::string_view table) const;

  sqlite3* handle() const { return db_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  sqlite3* db_ = nullptr;
  std::filesystem::path path_;
};

// A prepared statement. Parameters are bound in order (bind index advances); run() executes an
// INSERT/UPDATE/DELETE and resets for the next row; next() steps a SELECT.
class Statement {
 public:
  Statement(Database& db, const std::string& sql, std::string table);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Every bound value is also fed to `hash` while one is attached (a row's content hash).
  void attach(ContentHash* hash) { hash_ = hash; }
  Statement& integer(std::int64_t v);
  Statement& real(double v);
  Statement& text(std::string_view v);
  Statement& blob(std::span<const std::uint8_t> v);
  Statement& null();
  void run();
  bool next();

  bool is_null(int column) const;
  std::int64_t column_integer(int column) const;
  double column_real(int column) const;  // NULL reads as NaN (see ContentHash::real)
  std::string column_text(int column) const;
  std::span<const std::uint8_t> column_blob(int column) const;  // valid until the next step
  // The current row's hash: every column, by its stored type.
  std::uint64_t row_hash() const;
  const std::string& table() const { return table_; }

 private:
  void check_bind(int rc);
  Database& db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string table_;
  ContentHash* hash_ = nullptr;
  int index_ = 1;
};

}  // namespace coloc::slam::mapdb::detail
