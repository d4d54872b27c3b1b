#include "store/sqlite.hpp"

namespace tally::store {

void check(sqlite3* db, int rc, std::string_view what) {
  if (rc == SQLITE_OK || rc == SQLITE_ROW || rc == SQLITE_DONE) return;
  std::string message = "SQLite: " + std::string(sqlite3_errstr(rc));
  if (db && sqlite3_errmsg(db)) message += " (" + std::string(sqlite3_errmsg(db)) + ")";
  message += " in " + std::string(what.substr(0, 120));
  throw DbError(rc, "", message);
}

namespace {

class SqliteStatement final : public StatementImpl {
 public:
  SqliteStatement(sqlite3* db, std::string_view sql) : db_(db), sql_(sql) {
    check(db_, sqlite3_prepare_v2(db_, sql.data(), static_cast<int>(sql.size()), &stmt_, nullptr), sql);
  }
  ~SqliteStatement() override { sqlite3_finalize(stmt_); }

  void bindNull(int index) override { check(db_, sqlite3_bind_null(stmt_, index), sql_); }
  void bindInt(int index, int64_t value) override { check(db_, sqlite3_bind_int64(stmt_, index, value), sql_); }
  void bindDouble(int index, double value) override {
    check(db_, sqlite3_bind_double(stmt_, index, value), sql_);
  }
  void bindText(int index, std::string_view text) override {
    check(db_, sqlite3_bind_text64(stmt_, index, text.data(), text.size(), SQLITE_TRANSIENT, SQLITE_UTF8), sql_);
  }
  void bindBlob(int index, std::span<const uint8_t> blob) override {
    check(db_, sqlite3_bind_blob64(stmt_, index, blob.data(), blob.size(), SQLITE_TRANSIENT), sql_);
  }
  int parameterIndex(const char* name) const override { return sqlite3_bind_parameter_index(stmt_, name); }

  bool step() override {
    int rc = sqlite3_step(stmt_);
    check(db_, rc, sql_);
    return rc == SQLITE_ROW;
  }
  void reset() override {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }

  bool isNull(int column) const override { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
  int64_t getInt(int column) const override { return sqlite3_column_int64(stmt_, column); }
  double getDouble(int column) const override { return sqlite3_column_double(stmt_, column); }
  std::string getText(int column) const override {
    const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, column));
    return text ? std::string(text, static_cast<size_t>(sqlite3_column_bytes(stmt_, column))) : std::string();
  }
  std::vector<uint8_t> getBlob(int column) const override {
    const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(stmt_, column));
    int size = sqlite3_column_bytes(stmt_, column);
    return data ? std::vector<uint8_t>(data, data + size) : std::vector<uint8_t>();
  }
  int columnCount() const override { return sqlite3_column_count(stmt_); }
  std::string columnName(int column) const override {
    const char* name = sqlite3_column_name(stmt_, column);
    return name ? name : "";
  }
  const std::string& sql() const override { return sql_; }

 private:
  sqlite3* db_;
  std::string sql_;
  sqlite3_stmt* stmt_ = nullptr;
};

}  // namespace

SqliteConnection::~SqliteConnection() {
  if (owns_) sqlite3_close_v2(db_);
}

void SqliteConnection::exec(std::string_view sql) {
  std::string text(sql);
  char* error = nullptr;
  int rc = sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &error);
  if (rc != SQLITE_OK) {
    std::string message = "SQLite: " + std::string(error ? error : sqlite3_errstr(rc)) + " in " +
                          std::string(sql.substr(0, 120));
    sqlite3_free(error);
    throw DbError(sqlite3_extended_errcode(db_), "", message);
  }
}

std::unique_ptr<StatementImpl> SqliteConnection::prepare(std::string_view sql) {
  return std::make_unique<SqliteStatement>(db_, sql);
}

std::unique_ptr<Connection> openSqlite(const std::string& path, bool create, int busyTimeoutMs) {
  sqlite3* db = nullptr;
  int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
  int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  if (rc != SQLITE_OK) {
    std::string message =
        "opening database '" + path + "': " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
    sqlite3_close(db);
    throw DbError(rc, "", message);
  }
  sqlite3_extended_result_codes(db, 1);
  sqlite3_busy_timeout(db, busyTimeoutMs);
  return std::make_unique<SqliteConnection>(db, path);
}

}  // namespace tally::store
