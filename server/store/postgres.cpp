// The PostgreSQL engine of db.hpp, over libpq.
//
// Statements are prepared once per connection (server-side, named by a
// counter) and cached by their SQL text, so the store's habit of building a
// Statement per call costs one round trip per execution, not a parse and plan.
// Parameter types are left to the server to infer from their use; values go
// as text, blobs as binary bytea. Results come back whole as text and are
// parsed by the getters (booleans read as 1 and 0).
//
// A connection the server dropped is re-established at the next statement
// outside a transaction (prepared statements are prepared again); inside one,
// the statement fails with a connection error, which DbError::isConnectionLost
// recognises.
#include <libpq-fe.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <atomic>
#include <map>
#include <mutex>
#include <utility>

#include "store/db.hpp"

namespace tally::store {
namespace {

std::string trimmed(const char* message) {
  std::string s = message ? message : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

class PgConnection;

// observePostgresStatements: the observer, and whether one is set (read first, without the lock).
std::atomic<bool> gObserved{false};
std::mutex gObserverMutex;
StatementObserver gObserver;

class PgStatement final : public StatementImpl {
 public:
  PgStatement(PgConnection& db, std::string_view sql);
  ~PgStatement() override { clearResult(); }

  void bindNull(int index) override { slot(index).reset(); }
  void bindInt(int index, int64_t value) override { slot(index) = Value{std::to_string(value), false}; }
  void bindDouble(int index, double value) override { slot(index) = Value{postgresDoubleText(value), false}; }
  void bindText(int index, std::string_view text) override { slot(index) = Value{std::string(text), false}; }
  void bindBlob(int index, std::span<const uint8_t> blob) override {
    slot(index) = Value{std::string(reinterpret_cast<const char*>(blob.data()), blob.size()), true};
  }
  int parameterIndex(const char* name) const override {
    for (size_t k = 0; k < names_.size(); ++k) {
      if (names_[k] == name) return static_cast<int>(k) + 1;
    }
    return 0;
  }

  bool step() override;
  void reset() override {
    clearResult();
    for (auto& v : values_) v.reset();
  }

  bool isNull(int column) const override { return PQgetisnull(result_, row_, checked(column)) != 0; }
  int64_t getInt(int column) const override {
    const char* text = value(column);
    if (text[0] == 't' && text[1] == 0) return 1;
    if (text[0] == 'f' && text[1] == 0) return 0;
    int64_t out = 0;
    auto [end, ec] = std::from_chars(text, text + std::strlen(text), out);
    if (ec == std::errc() && *end == 0) return out;
    return static_cast<int64_t>(std::llround(std::strtod(text, nullptr)));  // numeric: "12.0000"
  }
  double getDouble(int column) const override { return std::strtod(value(column), nullptr); }
  std::string getText(int column) const override {
    int c = checked(column);
    return std::string(PQgetvalue(result_, row_, c), static_cast<size_t>(PQgetlength(result_, row_, c)));
  }
  std::vector<uint8_t> getBlob(int column) const override {
    size_t length = 0;
    unsigned char* bytes = PQunescapeBytea(reinterpret_cast<const unsigned char*>(value(column)), &length);
    if (!bytes) throw DbError(0, "", "PostgreSQL: cannot decode a bytea value in " + sql_.substr(0, 120));
    std::vector<uint8_t> out(bytes, bytes + length);
    PQfreemem(bytes);
    return out;
  }
  int columnCount() const override { return result_ ? PQnfields(result_) : 0; }
  std::string columnName(int column) const override {
    const char* name = result_ ? PQfname(result_, column) : nullptr;
    return name ? name : "";
  }
  const std::string& sql() const override { return sql_; }

 private:
  struct Value {
    std::string data;
    bool binary = false;
  };
  std::optional<Value>& slot(int index) {
    if (index < 1 || index > static_cast<int>(values_.size())) {
      throw DbError(0, "", "PostgreSQL: parameter " + std::to_string(index) + " out of range (" +
                               std::to_string(values_.size()) + ") in " + sql_.substr(0, 120));
    }
    return values_[static_cast<size_t>(index - 1)];
  }
  int checked(int column) const {
    if (!result_ || row_ < 0 || row_ >= PQntuples(result_) || column < 0 || column >= PQnfields(result_)) {
      throw DbError(0, "", "PostgreSQL: no column " + std::to_string(column) + " in this row of " +
                               sql_.substr(0, 120));
    }
    return column;
  }
  const char* value(int column) const { return PQgetvalue(result_, row_, checked(column)); }
  void clearResult() {
    if (result_) PQclear(result_);
    result_ = nullptr;
    row_ = -1;
  }

  PgConnection& db_;
  std::string sql_;  // as the store wrote it
  std::string pgSql_;
  std::vector<std::string> names_;
  std::vector<std::optional<Value>> values_;
  PGresult* result_ = nullptr;
  int row_ = -1;
};

class PgConnection final : public Connection {
 public:
  PgConnection(PGconn* conn, std::string url) : conn_(conn), url_(std::move(url)) {}
  ~PgConnection() override { PQfinish(conn_); }
  Engine engine() const override { return Engine::Postgres; }

  void exec(std::string_view sql) override {
    ensureConnected();
    PGresult* result = PQexec(conn_, std::string(sql).c_str());
    finish(result, sql);
  }
  std::unique_ptr<StatementImpl> prepare(std::string_view sql) override {
    return std::make_unique<PgStatement>(*this, sql);
  }
  int64_t changes() const override { return changes_; }
  std::string describe() const override { return redactUrl(url_); }
  void copyBegin(std::string_view copySql) override;
  void copyData(std::string_view data) override;
  void copyEnd() override;
  void copyAbort() noexcept override;

  // Prepares pgSql once (per connection and re-connection); the statement's name.
  const std::string& prepared(const std::string& pgSql, std::string_view original) {
    ensureConnected();
    auto it = prepared_.find(pgSql);
    if (it != prepared_.end()) return it->second;
    if (prepared_.size() >= kMaxPrepared) {
      // Variable IN lists make many texts; start over rather than grow without bound.
      PGresult* result = PQexec(conn_, "DEALLOCATE ALL");
      finish(result, "DEALLOCATE ALL");
      prepared_.clear();
    }
    std::string name = "tally_" + std::to_string(++counter_);
    PGresult* result = PQprepare(conn_, name.c_str(), pgSql.c_str(), 0, nullptr);
    finish(result, original);
    return prepared_.emplace(pgSql, std::move(name)).first->second;
  }

  // Checks a result, records the rows it changed, and throws on failure. Keeps
  // and returns a result with rows; frees the others.
  PGresult* finish(PGresult* result, std::string_view sql, bool keep = false) {
    ExecStatusType status = result ? PQresultStatus(result) : PGRES_FATAL_ERROR;
    if (status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK) {
      const char* tuples = PQcmdTuples(result);
      changes_ = tuples && *tuples ? std::strtoll(tuples, nullptr, 10) : 0;
      if (keep) return result;
      PQclear(result);
      return nullptr;
    }
    std::string state;
    std::string message = trimmed(result ? PQresultErrorMessage(result) : PQerrorMessage(conn_));
    if (result && PQresultErrorField(result, PG_DIAG_SQLSTATE)) state = PQresultErrorField(result, PG_DIAG_SQLSTATE);
    if (result) PQclear(result);
    if (PQstatus(conn_) != CONNECTION_OK) {
      if (state.empty()) state = "08006";  // connection_failure
      if (message.empty()) message = trimmed(PQerrorMessage(conn_));
    }
    throw DbError(0, state, "PostgreSQL: " + message + " in " + std::string(sql.substr(0, 120)));
  }

  PGconn* raw() { return conn_; }

 private:
  static constexpr size_t kMaxPrepared = 512;

  void ensureConnected() {
    if (PQstatus(conn_) == CONNECTION_OK) return;
    PQreset(conn_);
    prepared_.clear();  // they died with the old session
    if (PQstatus(conn_) != CONNECTION_OK) {
      throw DbError(0, "08006", "PostgreSQL: connection to " + describe() + " lost and not re-established: " +
                                    trimmed(PQerrorMessage(conn_)));
    }
    configure();
  }

 public:
  // The session's settings: UTC text, UTF-8, and the same float text whatever
  // the server's defaults; no JIT compilation, which the store's short
  // index-driven queries never repay (on a 1M-sample database it turned the
  // run's samples listing from 0.2 ms into 100 ms: docs/benchmarks.md).
  void configure() {
    finish(PQexec(conn_, kSessionSql), kSessionSql);
  }

 private:
  static constexpr const char* kSessionSql =
      "SET TIME ZONE 'UTC'; SET client_encoding = 'UTF8'; SET extra_float_digits = 1; SET jit = off";

  PGconn* conn_;
  std::string url_;
  std::map<std::string, std::string> prepared_;  // PostgreSQL SQL -> statement name
  uint64_t counter_ = 0;
  int64_t changes_ = 0;
  std::string copySql_;    // the open copy's command; empty when none is open
  bool copySent_ = false;  // every row of the open copy reached libpq
};

PgStatement::PgStatement(PgConnection& db, std::string_view sql) : db_(db), sql_(sql) {
  pgSql_ = toPostgresParameters(sql, &names_);
  values_.resize(names_.size());
  db_.prepared(pgSql_, sql_);  // prepared now, so a bad statement fails here as SQLite's does
}

bool PgStatement::step() {
  if (!result_) {
    if (gObserved.load(std::memory_order_relaxed)) {
      std::vector<std::optional<std::string>> parameters;
      for (const auto& v : values_) parameters.push_back(v && !v->binary ? std::optional(v->data) : std::nullopt);
      std::lock_guard lock(gObserverMutex);
      if (gObserver) gObserver(pgSql_, parameters);
    }
    const std::string& name = db_.prepared(pgSql_, sql_);
    std::vector<const char*> data(values_.size(), nullptr);
    std::vector<int> lengths(values_.size(), 0), formats(values_.size(), 0);
    for (size_t k = 0; k < values_.size(); ++k) {
      if (!values_[k]) continue;
      data[k] = values_[k]->data.c_str();
      lengths[k] = static_cast<int>(values_[k]->data.size());
      formats[k] = values_[k]->binary ? 1 : 0;
    }
    PGresult* result = PQexecPrepared(db_.raw(), name.c_str(), static_cast<int>(values_.size()), data.data(),
                                      lengths.data(), formats.data(), 0);
    result_ = db_.finish(result, sql_, /*keep=*/true);
    row_ = -1;
  }
  if (row_ + 1 < PQntuples(result_)) {
    ++row_;
    return true;
  }
  row_ = PQntuples(result_);
  return false;
}

void PgConnection::copyBegin(std::string_view copySql) {
  if (!copySql_.empty()) throw DbError(0, "", "PostgreSQL: a copy is open already: " + copySql_);
  ensureConnected();
  std::string sql(copySql);
  PGresult* started = PQexec(conn_, sql.c_str());
  if (!started || PQresultStatus(started) != PGRES_COPY_IN) {
    finish(started, sql);  // throws with the server's reason
    throw DbError(0, "", "PostgreSQL: " + sql + " did not start a copy");
  }
  PQclear(started);
  copySql_ = std::move(sql);
  copySent_ = true;
}

void PgConnection::copyData(std::string_view data) {
  if (copySql_.empty()) throw DbError(0, "", "PostgreSQL: rows sent with no copy open");
  // In pieces, so that libpq's buffer stays small whatever the batch.
  constexpr size_t kPiece = size_t{1} << 20;
  for (size_t at = 0; at < data.size() && copySent_; at += kPiece) {
    size_t length = std::min(kPiece, data.size() - at);
    copySent_ = PQputCopyData(conn_, data.data() + at, static_cast<int>(length)) == 1;
  }
}

void PgConnection::copyEnd() {
  if (copySql_.empty()) throw DbError(0, "", "PostgreSQL: no copy to end");
  std::string sql = std::exchange(copySql_, {});
  bool sent = copySent_;
  if (PQputCopyEnd(conn_, sent ? nullptr : "the client failed to send the rows") != 1) sent = false;
  // The command's own result, then nothing: every result is read so that the
  // connection is ready for the next statement.
  PGresult* result = PQgetResult(conn_);
  PGresult* rest = nullptr;
  while ((rest = PQgetResult(conn_)) != nullptr) PQclear(rest);
  finish(result, sql);
  if (!sent) throw DbError(0, "08006", "PostgreSQL: sending the rows of " + sql + " failed: " + trimmed(PQerrorMessage(conn_)));
}

void PgConnection::copyAbort() noexcept {
  if (copySql_.empty()) return;
  copySql_.clear();
  PQputCopyEnd(conn_, "the rows were refused before they were all sent");
  PGresult* result = nullptr;
  while ((result = PQgetResult(conn_)) != nullptr) PQclear(result);
}

void ignoreNotice(void*, const char*) {}

}  // namespace

void observePostgresStatements(StatementObserver observer) {
  std::lock_guard lock(gObserverMutex);
  gObserver = std::move(observer);
  gObserved = static_cast<bool>(gObserver);
}

void appendPostgresDouble(std::string& out, double value) {
  if (std::isnan(value)) {
    out += "NaN";
  } else if (std::isinf(value)) {
    out += value > 0 ? "Infinity" : "-Infinity";
  } else {
    char text[32];
    auto [end, ec] = std::to_chars(text, text + sizeof text, value);  // shortest exact form
    (void)ec;
    out.append(text, end);
  }
}

std::string postgresDoubleText(double value) {
  std::string text;
  appendPostgresDouble(text, value);
  return text;
}

std::unique_ptr<Connection> openPostgres(const std::string& url, int connectTimeoutSeconds) {
  // connect_timeout goes in as a keyword beside the URL (expand_dbname).
  std::string timeout = std::to_string(connectTimeoutSeconds);
  const char* keywords[] = {"dbname", "connect_timeout", "application_name", nullptr};
  const char* values[] = {url.c_str(), timeout.c_str(), "tallyd", nullptr};
  PGconn* conn = PQconnectdbParams(keywords, values, /*expand_dbname=*/1);
  if (!conn) throw DbError(0, "08006", "PostgreSQL: out of memory connecting to " + redactUrl(url));
  if (PQstatus(conn) != CONNECTION_OK) {
    std::string message = trimmed(PQerrorMessage(conn));
    PQfinish(conn);
    throw DbError(0, "08006", "PostgreSQL: cannot connect to " + redactUrl(url) + ": " + message);
  }
  PQsetNoticeProcessor(conn, ignoreNotice, nullptr);
  auto connection = std::make_unique<PgConnection>(conn, url);
  connection->configure();
  return connection;
}

}  // namespace tally::store
