#include "store/sqlite.hpp"

#include <limits>

namespace tally::store {

void check(sqlite3* db, int rc, std::string_view what) {
  if (rc == SQLITE_OK || rc == SQLITE_ROW || rc == SQLITE_DONE) return;
  std::string message = "SQLite: " + std::string(sqlite3_errstr(rc));
  if (db && sqlite3_errmsg(db)) message += " (" + std::string(sqlite3_errmsg(db)) + ")";
  message += " in " + std::string(what.substr(0, 120));
  throw SqliteError(rc, message);
}

void exec(sqlite3* db, std::string_view sql) {
  std::string text(sql);
  char* error = nullptr;
  int rc = sqlite3_exec(db, text.c_str(), nullptr, nullptr, &error);
  if (rc != SQLITE_OK) {
    std::string message = "SQLite: " + std::string(error ? error : sqlite3_errstr(rc)) + " in " +
                          std::string(sql.substr(0, 120));
    sqlite3_free(error);
    throw SqliteError(rc, message);
  }
}

Statement::Statement(sqlite3* db, std::string_view sql) : db_(db) {
  check(db_, sqlite3_prepare_v2(db_, sql.data(), static_cast<int>(sql.size()), &stmt_, nullptr), sql);
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

Statement::Statement(Statement&& other) noexcept : db_(other.db_), stmt_(other.stmt_) {
  other.stmt_ = nullptr;
}

Statement& Statement::bind(int index, std::nullptr_t) {
  check(db_, sqlite3_bind_null(stmt_, index), sqlite3_sql(stmt_));
  return *this;
}
Statement& Statement::bind(int index, int64_t value) {
  check(db_, sqlite3_bind_int64(stmt_, index, value), sqlite3_sql(stmt_));
  return *this;
}
Statement& Statement::bind(int index, double value) {
  check(db_, sqlite3_bind_double(stmt_, index, value), sqlite3_sql(stmt_));
  return *this;
}
Statement& Statement::bind(int index, std::string_view text) {
  check(db_, sqlite3_bind_text64(stmt_, index, text.data(), text.size(), SQLITE_TRANSIENT, SQLITE_UTF8),
        sqlite3_sql(stmt_));
  return *this;
}
Statement& Statement::bind(int index, std::span<const uint8_t> blob) {
  check(db_, sqlite3_bind_blob64(stmt_, index, blob.data(), blob.size(), SQLITE_TRANSIENT),
        sqlite3_sql(stmt_));
  return *this;
}
Statement& Statement::bind(int index, const nlohmann::json& value) {
  // Replace invalid UTF-8 rather than throw: notes and labels come from captures.
  return bind(index, std::string_view(value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)));
}

int Statement::parameterIndex(const char* name) const {
  int index = sqlite3_bind_parameter_index(stmt_, name);
  if (index == 0)
    throw SqliteError(SQLITE_RANGE, std::string("no parameter ") + name + " in " + sqlite3_sql(stmt_));
  return index;
}

bool Statement::step() {
  int rc = sqlite3_step(stmt_);
  check(db_, rc, sqlite3_sql(stmt_));
  return rc == SQLITE_ROW;
}

void Statement::run() {
  while (step()) {
  }
}

void Statement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

bool Statement::isNull(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
int64_t Statement::getInt(int column) const { return sqlite3_column_int64(stmt_, column); }
double Statement::getDouble(int column) const { return sqlite3_column_double(stmt_, column); }

std::string Statement::getText(int column) const {
  const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, column));
  return text ? std::string(text, static_cast<size_t>(sqlite3_column_bytes(stmt_, column))) : std::string();
}

std::vector<uint8_t> Statement::getBlob(int column) const {
  const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(stmt_, column));
  int size = sqlite3_column_bytes(stmt_, column);
  return data ? std::vector<uint8_t>(data, data + size) : std::vector<uint8_t>();
}

nlohmann::json Statement::getJson(int column) const {
  if (isNull(column)) return nullptr;
  return nlohmann::json::parse(getText(column));
}

std::optional<int64_t> Statement::getOptInt(int column) const {
  return isNull(column) ? std::nullopt : std::optional<int64_t>(getInt(column));
}
std::optional<double> Statement::getOptDouble(int column) const {
  return isNull(column) ? std::nullopt : std::optional<double>(getDouble(column));
}
std::optional<std::string> Statement::getOptText(int column) const {
  return isNull(column) ? std::nullopt : std::optional<std::string>(getText(column));
}

Transaction::Transaction(sqlite3* db, Kind kind) : db_(db) {
  exec(db_, kind == Kind::Write ? "BEGIN IMMEDIATE" : "BEGIN");
}

Transaction::~Transaction() {
  if (open_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::commit() {
  exec(db_, "COMMIT");
  open_ = false;
}

}  // namespace tally::store
