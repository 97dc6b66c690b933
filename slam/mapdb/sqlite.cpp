#include "slam/mapdb/sqlite.hpp"

#include <sqlite3.h>

#include <bit>
#include <cmath>
#include <cstring>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::slam::mapdb::detail {

namespace {

enum Tag : std::uint64_t { kInteger = 1, kReal = 2, kText = 3, kBlob = 4, kNull = 5 };

}  // namespace

// ------------------------------------------------------------------------------ ContentHash

void ContentHash::word(std::uint64_t w) {
  h_ = (h_ ^ w) * 0x9e3779b97f4a7c15ULL;
  h_ ^= h_ >> 29;
}

void ContentHash::bytes(std::uint64_t tag, const std::uint8_t* data, std::size_t size) {
  word(tag);
  word(size);
  std::size_t i = 0;
  for (; i + 8 <= size; i += 8) {
    std::uint64_t w = 0;
    for (int b = 0; b < 8; ++b)
      w |= static_cast<std::uint64_t>(data[i + static_cast<std::size_t>(b)]) << (8 * b);
    word(w);
  }
  if (i < size) {
    std::uint64_t w = 0;
    for (int b = 0; i + static_cast<std::size_t>(b) < size; ++b)
      w |= static_cast<std::uint64_t>(data[i + static_cast<std::size_t>(b)]) << (8 * b);
    word(w);
  }
}

void ContentHash::integer(std::int64_t v) {
  word(kInteger);
  word(static_cast<std::uint64_t>(v));
}

void ContentHash::real(double v) {
  if (std::isnan(v)) return null();
  // SQLite stores an integral value of a REAL column as an integer, so -0.0 reads back as 0.0.
  if (v == 0.0) v = 0.0;
  word(kReal);
  word(std::bit_cast<std::uint64_t>(v));
}

void ContentHash::text(std::string_view v) {
  bytes(kText, reinterpret_cast<const std::uint8_t*>(v.data()), v.size());
}

void ContentHash::blob(std::span<const std::uint8_t> v) {
  bytes(kBlob, v.data(), v.size());
}

void ContentHash::null() {
  word(kNull);
}

// --------------------------------------------------------------------------------- Database

Database::Database(const std::filesystem::path& path, Mode mode) : path_(path) {
  if (mode != Mode::kCreate) check_input_file(path, "map file");
  const int flags =
      mode == Mode::kCreate ? SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE : SQLITE_OPEN_READONLY;
  const int rc = sqlite3_open_v2(path.c_str(), &db_, flags | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    sqlite3_close_v2(db_);
    db_ = nullptr;
    throw Error("cannot open the map database: " + message, {.file = path.string()});
  }
  sqlite3_extended_result_codes(db_, 1);
}

Database::~Database() {
  if (db_) sqlite3_close_v2(db_);
}

void Database::fail(int rc, std::string_view what, std::string_view table) const {
  std::string message = "SQLite: ";
  message += db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
  const int primary = rc & 0xff;
  if (primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB)
    message += " (the file is damaged, truncated or not a map database)";
  if (!what.empty()) {
    message += " while ";
    message += what;
  }
  throw Error(message, {.file = path_.string(), .field = std::string(table)});
}

void Database::exec(const std::string& sql, std::string_view table) {
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) fail(rc, sql.substr(0, 60), table);
}

std::int64_t Database::query_integer(const std::string& sql, std::string_view table) {
  Statement s(*this, sql, std::string(table));
  if (!s.next()) fail(SQLITE_ERROR, "reading " + sql, table);
  return s.column_integer(0);
}

void Database::close() {
  if (!db_) return;
  const int rc = sqlite3_close(db_);
  if (rc != SQLITE_OK) fail(rc, "closing", {});
  db_ = nullptr;
}

// -------------------------------------------------------------------------------- Statement

Statement::Statement(Database& db, const std::string& sql, std::string table)
    : db_(db), table_(std::move(table)) {
  const int rc =
      sqlite3_prepare_v3(db.handle(), sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT, &stmt_, nullptr);
  if (rc != SQLITE_OK) db_.fail(rc, "preparing " + sql.substr(0, 60), table_);
}

Statement::~Statement() {
  sqlite3_finalize(stmt_);
}

void Statement::check_bind(int rc) {
  if (rc != SQLITE_OK) db_.fail(rc, "binding a value", table_);
  ++index_;
}

Statement& Statement::integer(std::int64_t v) {
  if (hash_) hash_->integer(v);
  check_bind(sqlite3_bind_int64(stmt_, index_, v));
  return *this;
}

Statement& Statement::real(double v) {
  if (hash_) hash_->real(v);
  check_bind(sqlite3_bind_double(stmt_, index_, v));
  return *this;
}

Statement& Statement::text(std::string_view v) {
  if (hash_) hash_->text(v);
  check_bind(sqlite3_bind_text64(stmt_, index_, v.data(), v.size(), SQLITE_TRANSIENT, SQLITE_UTF8));
  return *this;
}

Statement& Statement::blob(std::span<const std::uint8_t> v) {
  if (hash_) hash_->blob(v);
  // A null pointer would bind NULL, not an empty blob. SQLITE_STATIC: the caller keeps the
  // bytes alive until run(), so SQLite copies them once, into its page, and never in between.
  check_bind(v.empty() ? sqlite3_bind_zeroblob(stmt_, index_, 0)
                       : sqlite3_bind_blob64(stmt_, index_, v.data(), v.size(), SQLITE_STATIC));
  return *this;
}

Statement& Statement::null() {
  if (hash_) hash_->null();
  check_bind(sqlite3_bind_null(stmt_, index_));
  return *this;
}

void Statement::run() {
  const int rc = sqlite3_step(stmt_);
  if (rc != SQLITE_DONE) db_.fail(rc, "writing a row", table_);
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
  index_ = 1;
}

bool Statement::next() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  db_.fail(rc, "reading a row", table_);
}

bool Statement::is_null(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

std::int64_t Statement::column_integer(int column) const {
  return sqlite3_column_int64(stmt_, column);
}

double Statement::column_real(int column) const {
  if (is_null(column)) return std::nan("");
  return sqlite3_column_double(stmt_, column);
}

std::string Statement::column_text(int column) const {
  const auto* p = sqlite3_column_text(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(n))
           : std::string();
}

std::span<const std::uint8_t> Statement::column_blob(int column) const {
  const void* p = sqlite3_column_blob(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  if (!p || n <= 0) return {};
  return {static_cast<const std::uint8_t*>(p), static_cast<std::size_t>(n)};
}

std::uint64_t Statement::row_hash() const {
  ContentHash h;
  const int n = sqlite3_column_count(stmt_);
  for (int c = 0; c < n; ++c) {
    switch (sqlite3_column_type(stmt_, c)) {
      case SQLITE_INTEGER:
        h.integer(sqlite3_column_int64(stmt_, c));
        break;
      case SQLITE_FLOAT:
        h.real(sqlite3_column_double(stmt_, c));
        break;
      case SQLITE_TEXT:
        h.text(column_text(c));
        break;
      case SQLITE_BLOB:
        h.blob(column_blob(c));
        break;
      default:
        h.null();
        break;
    }
  }
  return h.value();
}

}  // namespace coloc::slam::mapdb::detail
