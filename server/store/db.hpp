// The store's two database engines behind one small interface: a Connection
// (SQLite file or PostgreSQL server), a prepared Statement (bind by index or
// name, step, column getters) and a Transaction that rolls back unless
// committed. Values only ever reach SQL through bind(); never build SQL text
// from values.
//
// The store's SQL is written once, in the dialect both engines accept:
// parameters are "?N" (or "?", numbered as SQLite numbers them: one more than
// the largest so far) and ":name"; the PostgreSQL connection rewrites them to
// "$N" before preparing. What the engines spell differently (the current
// time, JSON paths, row locks) comes from the dialect functions below.
//
// Failures throw DbError (with the engine's message and the statement's SQL);
// Store's public functions catch it and return tally::Result.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace tally::store {

enum class Engine { Sqlite, Postgres };

class DbError : public std::runtime_error {
 public:
  // code: SQLite's extended result code, or 0 for PostgreSQL; sqlState: the
  // PostgreSQL SQLSTATE ("23505"), or empty for SQLite.
  DbError(int code, std::string sqlState, const std::string& message)
      : std::runtime_error(message), code_(code), sqlState_(std::move(sqlState)) {}
  int code() const { return code_; }
  const std::string& sqlState() const { return sqlState_; }
  // A constraint (unique, not null, check, foreign key) refused the write.
  bool isConstraint() const;
  // The connection is gone (server down, network): worth retrying later.
  bool isConnectionLost() const;

 private:
  int code_;
  std::string sqlState_;
};

// One prepared statement of one engine; used through Statement.
class StatementImpl {
 public:
  virtual ~StatementImpl() = default;
  virtual void bindNull(int index) = 0;
  virtual void bindInt(int index, int64_t value) = 0;
  virtual void bindDouble(int index, double value) = 0;
  virtual void bindText(int index, std::string_view text) = 0;
  virtual void bindBlob(int index, std::span<const uint8_t> blob) = 0;
  virtual int parameterIndex(const char* name) const = 0;  // 0: no such parameter
  virtual bool step() = 0;
  virtual void reset() = 0;
  virtual bool isNull(int column) const = 0;
  virtual int64_t getInt(int column) const = 0;
  virtual double getDouble(int column) const = 0;
  virtual std::string getText(int column) const = 0;
  virtual std::vector<uint8_t> getBlob(int column) const = 0;
  virtual int columnCount() const = 0;  // of the current row
  virtual std::string columnName(int column) const = 0;
  virtual const std::string& sql() const = 0;
};

class Connection {
 public:
  virtual ~Connection() = default;
  virtual Engine engine() const = 0;
  // SQL text without parameters (pragmas, migrations, BEGIN/COMMIT); may hold several statements.
  virtual void exec(std::string_view sql) = 0;
  virtual std::unique_ptr<StatementImpl> prepare(std::string_view sql) = 0;
  // Rows changed by the last INSERT, UPDATE or DELETE on this connection.
  virtual int64_t changes() const = 0;
  // What the connection is, for messages: the file path, or the server without the password.
  virtual std::string describe() const = 0;
  // PostgreSQL's COPY ... FROM STDIN, rows in COPY's text format: copyBegin
  // runs `copySql`; copyData sends rows, which the server stores while the
  // caller makes the next; copyEnd ends the copy and throws the server's
  // reason for any row it refused. Nothing else runs on the connection while
  // a copy is open; copyAbort ends an open copy refused (the transaction then
  // rolls back) and does nothing otherwise. SQLite has no COPY: they throw.
  virtual void copyBegin(std::string_view copySql);
  virtual void copyData(std::string_view data);
  virtual void copyEnd();
  virtual void copyAbort() noexcept {}
};

// Opens a SQLite file (created when create is set), with extended result codes
// and busy_timeout set.
std::unique_ptr<Connection> openSqlite(const std::string& path, bool create, int busyTimeoutMs);
// Opens a PostgreSQL connection from a libpq URL (postgresql://user@host:port/db?...).
std::unique_ptr<Connection> openPostgres(const std::string& url, int connectTimeoutSeconds = 10);
// A double as the PostgreSQL connection sends it: the shortest text that
// reads back as the same value; NaN and the infinities spelled as the server reads them.
std::string postgresDoubleText(double value);
// The same text appended to `out`, without a string of its own (COPY's rows).
void appendPostgresDouble(std::string& out, double value);
// Sees every statement a PostgreSQL connection of this process executes, as
// sent (its "$N" text) with its parameters' text (nullopt: NULL or a blob),
// from the executing thread. For benchmarks that EXPLAIN what the store ran
// (benchmarks/query_plans.cpp); an empty function stops it. Costs an
// atomic load per statement while none is set.
using StatementObserver =
    std::function<void(const std::string& sql, const std::vector<std::optional<std::string>>& parameters)>;
void observePostgresStatements(StatementObserver observer);
// True for "postgresql://..." and "postgres://...".
bool isPostgresUrl(std::string_view location);
// The URL with its password, if any, replaced by "***", for logs and errors.
std::string redactUrl(std::string_view url);

// Rewrites "?N", "?" and ":name" parameters to PostgreSQL's "$N", outside
// string literals, quoted identifiers and comments. names receives each
// ":name" in order of its number (names[k] is "$k+1"'s name, "" for numbered ones).
std::string toPostgresParameters(std::string_view sql, std::vector<std::string>* names = nullptr);

class Statement {
 public:
  Statement(Connection& db, std::string_view sql) : impl_(db.prepare(sql)) {}
  Statement(Connection* db, std::string_view sql) : Statement(*db, sql) {}

  // Parameters are 1-based. Names include their prefix (":id").
  Statement& bind(int index, std::nullptr_t) { return impl_->bindNull(index), *this; }
  Statement& bind(int index, int64_t value) { return impl_->bindInt(index, value), *this; }
  Statement& bind(int index, int value) { return bind(index, int64_t{value}); }
  Statement& bind(int index, bool value) { return bind(index, int64_t{value ? 1 : 0}); }
  Statement& bind(int index, double value) { return impl_->bindDouble(index, value), *this; }
  Statement& bind(int index, std::string_view text) { return impl_->bindText(index, text), *this; }
  Statement& bind(int index, const char* text) { return bind(index, std::string_view(text)); }
  Statement& bind(int index, const std::string& text) { return bind(index, std::string_view(text)); }
  Statement& bind(int index, std::span<const uint8_t> blob) { return impl_->bindBlob(index, blob), *this; }
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
  bool step() { return impl_->step(); }
  // Steps to completion, for statements without rows.
  void run() {
    while (step()) {
    }
  }
  // Ready to run again with new bindings.
  void reset() { impl_->reset(); }

  bool isNull(int column) const { return impl_->isNull(column); }
  int64_t getInt(int column) const { return impl_->getInt(column); }
  double getDouble(int column) const { return impl_->getDouble(column); }
  std::string getText(int column) const { return impl_->getText(column); }
  std::vector<uint8_t> getBlob(int column) const { return impl_->getBlob(column); }
  nlohmann::json getJson(int column) const;  // NULL reads as null
  std::optional<int64_t> getOptInt(int column) const;
  std::optional<double> getOptDouble(int column) const;
  std::optional<std::string> getOptText(int column) const;
  int columnCount() const { return impl_->columnCount(); }
  // The column called `name` (as the engine names it: a column's name
  // without its table, or the name given by AS). Throws DbError when the row
  // has no such column.
  int column(std::string_view name) const;
  const std::string& sql() const { return impl_->sql(); }

 private:
  int parameterIndex(const char* name) const;
  std::unique_ptr<StatementImpl> impl_;
};

// Reads a row's columns in the order its SELECT lists them: each get takes
// the next column, so a reader names no column numbers and follows the
// SELECT's order. end() checks that the row had exactly the columns read:
// a column added to a SELECT without its read (or the other way round) then
// fails loudly instead of shifting every column after it.
class RowReader {
 public:
  explicit RowReader(const Statement& row) : row_(row) {}
  bool isNull() const { return row_.isNull(peek()); }  // the next column's, without taking it
  int64_t getInt() { return row_.getInt(next()); }
  double getDouble() { return row_.getDouble(next()); }
  std::string getText() { return row_.getText(next()); }
  nlohmann::json getJson() { return row_.getJson(next()); }
  std::optional<int64_t> getOptInt() { return row_.getOptInt(next()); }
  std::optional<double> getOptDouble() { return row_.getOptDouble(next()); }
  std::optional<std::string> getOptText() { return row_.getOptText(next()); }
  // Throws DbError unless every column of the row was read.
  void end() const;

 private:
  int peek() const;  // the next column; throws DbError past the last one
  int next() { return (void)peek(), at_++; }
  const Statement& row_;
  int at_ = 0;
};

// Read: a consistent snapshot for multi-statement reads (SQLite BEGIN;
// PostgreSQL REPEATABLE READ, READ ONLY). Write: SQLite BEGIN IMMEDIATE
// (takes the write lock up front, so no deadlock on upgrade); PostgreSQL
// BEGIN (READ COMMITTED, with row locks where the SQL asks for them).
class Transaction {
 public:
  enum class Kind { Read, Write };
  Transaction(Connection& db, Kind kind);
  Transaction(Connection* db, Kind kind) : Transaction(*db, kind) {}
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  Connection& db_;
  bool open_ = true;
};

// ---- what the dialects spell differently ------------------------------------------

// The current UTC time as ISO-8601 text with milliseconds ("2026-11-21T06:30:00.123Z").
const char* nowSql(const Connection& db);
// The current time in milliseconds since 1970 (the database's clock, shared by every host).
const char* nowMsSql(const Connection& db);
// Appended to a SELECT that picks rows to claim: row locks that other
// claimers skip (PostgreSQL); nothing for SQLite, whose write transaction
// already excludes every other writer.
const char* skipLockedSql(const Connection& db);

}  // namespace tally::store
