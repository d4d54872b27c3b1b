// Thin RAII over the SQLite C API: a prepared Statement (bind by index or
// name, step, column getters) and a Transaction that rolls back unless
// committed. Values only ever reach SQL through bind(); never build SQL text
// from values.
//
// Failures throw SqliteError (with SQLite's message and the statement's SQL);
// Store's public functions catch it and return tally::Result.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace tally::store {

class SqliteError : public std::runtime_error {
 public:
  SqliteError(int code, const std::string& message) : std::runtime_error(message), code_(code) {}
  int code() const { return code_; }

 private:
  int code_;
};

// Throws SqliteError when rc is not SQLITE_OK/ROW/DONE.
void check(sqlite3* db, int rc, std::string_view what);
// Runs SQL text without parameters (pragmas, migrations, BEGIN/COMMIT).
void exec(sqlite3* db, std::string_view sql);

class Statement {
 public:
  Statement(sqlite3* db, std::string_view sql);
  ~Statement();
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&&) = delete;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Parameters are 1-based, as in SQLite. Names include their prefix (":id").
  Statement& bind(int index, std::nullptr_t);
  Statement& bind(int index, int64_t value);
  Statement& bind(int index, int value) { return bind(index, int64_t{value}); }
  Statement& bind(int index, double value);
  Statement& bind(int index, std::string_view text);
  Statement& bind(int index, const char* text) { return bind(index, std::string_view(text)); }
  Statement& bind(int index, const std::string& text) { return bind(index, std::string_view(text)); }
  Statement& bind(int index, std::span<const uint8_t> blob);
  Statement& bind(int index, const nlohmann::json& value);  // stored as compact JSON text
  template <class T>
  Statement& bind(int index, const std::optional<T>& value) {
    return value ? bind(index, *value) : bind(index, nullptr);
  }
  template <class T>
  Statement& bind(const char* name, const T& value) {
    return bind(parameterIndex(name), value);
  }

  // True while a row is available; false when done.
  bool step();
  // Steps to completion, for statements without rows.
  void run();
  // Ready to run again with new bindings.
  void reset();

  bool isNull(int column) const;
  int64_t getInt(int column) const;
  double getDouble(int column) const;
  std::string getText(int column) const;
  std::vector<uint8_t> getBlob(int column) const;
  nlohmann::json getJson(int column) const;  // NULL reads as null
  std::optional<int64_t> getOptInt(int column) const;
  std::optional<double> getOptDouble(int column) const;
  std::optional<std::string> getOptText(int column) const;

 private:
  int parameterIndex(const char* name) const;
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN (deferred: for consistent multi-statement reads) or BEGIN IMMEDIATE
// (writes: takes the write lock up front, so no deadlock on upgrade).
class Transaction {
 public:
  enum class Kind { Read, Write };
  Transaction(sqlite3* db, Kind kind);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  sqlite3* db_;
  bool open_ = true;
};

}  // namespace tally::store
