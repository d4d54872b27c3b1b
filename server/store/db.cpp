// The engine-neutral half of db.hpp: Statement's JSON and optional getters,
// Transaction, the dialect fragments and the parameter rewriting for PostgreSQL.
#include "store/db.hpp"
#include "store/fault.hpp"

#include <sqlite3.h>

#include <cctype>

namespace tally::store {

bool DbError::isConstraint() const {
  if (!sqlState_.empty()) return sqlState_.compare(0, 2, "23") == 0;  // integrity_constraint_violation
  return (code_ & 0xff) == SQLITE_CONSTRAINT;
}

bool DbError::isConnectionLost() const {
  // 08: connection_exception; 57P01..03: admin shutdown, crash shutdown, cannot connect now.
  return sqlState_.compare(0, 2, "08") == 0 || sqlState_ == "57P01" || sqlState_ == "57P02" ||
         sqlState_ == "57P03";
}

const char* toString(Fault fault) {
  switch (fault) {
    case Fault::kNone: return "none";
    case Fault::kBusy: return "busy";
    case Fault::kFull: return "full";
    case Fault::kIoError: return "io_error";
    case Fault::kReadOnly: return "read_only";
    case Fault::kDamaged: return "damaged";
    case Fault::kUnreachable: return "unreachable";
  }
  return "none";
}

std::string describe(Fault fault) {
  switch (fault) {
    case Fault::kNone: return "no fault";
    case Fault::kBusy: return "the store is busy (a lock was held past the busy timeout)";
    case Fault::kFull: return "the disk holding the store is full";
    case Fault::kIoError: return "the store's file cannot be read or written (I/O error)";
    case Fault::kReadOnly: return "the store cannot be written (read-only file or folder)";
    case Fault::kDamaged: return "the store's file is damaged";
    case Fault::kUnreachable: return "the store's server cannot be reached";
  }
  return "no fault";
}

bool isWriteFault(Fault fault) {
  return fault == Fault::kFull || fault == Fault::kIoError || fault == Fault::kReadOnly;
}

Fault faultOf(const DbError& error) {
  if (!error.sqlState().empty() || error.code() == 0) {
    const std::string& s = error.sqlState();
    if (error.isConnectionLost()) return Fault::kUnreachable;
    if (s == "53100") return Fault::kFull;  // disk_full
    if (s.compare(0, 2, "53") == 0 || s == "55P03" || s == "40001" || s == "40P01" || s == "57014") {
      return Fault::kBusy;  // insufficient resources, lock timeout, serialisation, deadlock, cancelled
    }
    if (s == "58030") return Fault::kIoError;                  // io_error
    if (s == "XX001" || s == "XX002") return Fault::kDamaged;  // data or index corrupted
    if (s == "25006") return Fault::kReadOnly;                 // read_only_sql_transaction
    return Fault::kNone;
  }
  switch (error.code() & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED: return Fault::kBusy;
    case SQLITE_FULL: return Fault::kFull;
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_NOLFS: return Fault::kIoError;
    case SQLITE_READONLY: return Fault::kReadOnly;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB: return Fault::kDamaged;
    default: return Fault::kNone;
  }
}

Fault faultOf(const std::exception& error) {
  const auto* db = dynamic_cast<const DbError*>(&error);
  return db ? faultOf(*db) : Fault::kNone;
}

namespace {
thread_local Fault tLastFault = Fault::kNone;
}  // namespace

Fault lastFault() { return tLastFault; }
void setLastFault(Fault fault) { tLastFault = fault; }

void Connection::copyBegin(std::string_view copySql) {
  throw DbError(0, "", "this engine has no COPY: " + std::string(copySql.substr(0, 120)));
}
void Connection::copyData(std::string_view) { throw DbError(0, "", "this engine has no COPY"); }
void Connection::copyEnd() { throw DbError(0, "", "this engine has no COPY"); }

bool isPostgresUrl(std::string_view location) {
  return location.starts_with("postgresql://") || location.starts_with("postgres://");
}

std::string redactUrl(std::string_view url) {
  // scheme://user:password@host...: the password is between the first ':' after
  // the scheme and the '@' that ends the user information.
  size_t scheme = url.find("://");
  if (scheme == std::string_view::npos) return std::string(url);
  size_t start = scheme + 3;
  size_t at = url.find('@', start);
  size_t slash = url.find('/', start);
  if (at == std::string_view::npos || (slash != std::string_view::npos && slash < at)) {
    // No user information; a password may still be a query parameter.
    std::string out(url);
    size_t p = out.find("password=");
    if (p != std::string::npos) {
      size_t end = out.find('&', p);
      out.replace(p + 9, (end == std::string::npos ? out.size() : end) - (p + 9), "***");
    }
    return out;
  }
  size_t colon = url.find(':', start);
  if (colon == std::string_view::npos || colon > at) return std::string(url);
  return std::string(url.substr(0, colon + 1)) + "***" + std::string(url.substr(at));
}

std::string toPostgresParameters(std::string_view sql, std::vector<std::string>* names) {
  std::string out;
  out.reserve(sql.size() + 8);
  std::vector<std::string> assigned;  // assigned[k]: the name of $k+1 ("" when numbered)
  int largest = 0;
  auto number = [&](int n, const std::string& name) {
    if (n > largest) largest = n;
    if (static_cast<int>(assigned.size()) < n) assigned.resize(static_cast<size_t>(n));
    if (!name.empty()) assigned[static_cast<size_t>(n - 1)] = name;
    out += '$';
    out += std::to_string(n);
  };
  for (size_t i = 0; i < sql.size();) {
    char c = sql[i];
    if (c == '\'' || c == '"') {  // a literal or quoted identifier, copied whole ('' and "" escape)
      size_t end = i + 1;
      while (end < sql.size()) {
        if (sql[end] == c) {
          if (end + 1 < sql.size() && sql[end + 1] == c) {
            end += 2;
            continue;
          }
          break;
        }
        ++end;
      }
      end = std::min(end + 1, sql.size());
      out.append(sql.substr(i, end - i));
      i = end;
    } else if (c == '-' && i + 1 < sql.size() && sql[i + 1] == '-') {
      size_t end = sql.find('\n', i);
      end = end == std::string_view::npos ? sql.size() : end;
      out.append(sql.substr(i, end - i));
      i = end;
    } else if (c == '?') {
      size_t end = i + 1;
      while (end < sql.size() && std::isdigit(static_cast<unsigned char>(sql[end]))) ++end;
      number(end > i + 1 ? std::stoi(std::string(sql.substr(i + 1, end - i - 1))) : largest + 1, "");
      i = end;
    } else if (c == ':' && i + 1 < sql.size() && i > 0 && sql[i - 1] == ':') {
      out += c;  // the second ':' of a "::type" cast
      ++i;
    } else if (c == ':' && i + 1 < sql.size() &&
               (std::isalpha(static_cast<unsigned char>(sql[i + 1])) || sql[i + 1] == '_') &&
               !(i + 1 < sql.size() && sql[i + 1] == ':')) {
      size_t end = i + 1;
      while (end < sql.size() && (std::isalnum(static_cast<unsigned char>(sql[end])) || sql[end] == '_')) ++end;
      std::string name(sql.substr(i, end - i));
      int n = 0;
      for (size_t k = 0; k < assigned.size(); ++k) {
        if (assigned[k] == name) n = static_cast<int>(k) + 1;
      }
      number(n ? n : largest + 1, name);
      i = end;
    } else {
      out += c;
      ++i;
    }
  }
  if (names) *names = std::move(assigned);
  return out;
}

Statement& Statement::bind(int index, const nlohmann::json& value) {
  // Replace invalid UTF-8 rather than throw: notes and labels come from captures.
  return bind(index, std::string_view(value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)));
}

int Statement::parameterIndex(const char* name) const {
  int index = impl_->parameterIndex(name);
  if (index == 0) throw DbError(SQLITE_RANGE, "", std::string("no parameter ") + name + " in " + impl_->sql());
  return index;
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

int Statement::column(std::string_view name) const {
  for (int c = 0; c < columnCount(); ++c) {
    if (impl_->columnName(c) == name) return c;
  }
  throw DbError(0, "", "no column " + std::string(name) + " in " + impl_->sql());
}

int RowReader::peek() const {
  if (at_ >= row_.columnCount()) {
    throw DbError(0, "", "read past the " + std::to_string(row_.columnCount()) + " columns of " + row_.sql());
  }
  return at_;
}

void RowReader::end() const {
  if (at_ != row_.columnCount()) {
    throw DbError(0, "",
                  "read " + std::to_string(at_) + " of the " + std::to_string(row_.columnCount()) +
                      " columns of " + row_.sql());
  }
}

Transaction::Transaction(Connection& db, Kind kind) : db_(db) {
  if (db_.engine() == Engine::Sqlite) {
    db_.exec(kind == Kind::Write ? "BEGIN IMMEDIATE" : "BEGIN");
  } else {
    db_.exec(kind == Kind::Write ? "BEGIN" : "BEGIN ISOLATION LEVEL REPEATABLE READ, READ ONLY");
  }
}

Transaction::~Transaction() {
  if (!open_) return;
  try {
    db_.exec("ROLLBACK");
  } catch (const std::exception&) {
    // The connection is gone; so is the transaction.
  }
}

void Transaction::commit() {
  db_.exec("COMMIT");
  open_ = false;
}

const char* nowSql(const Connection& db) {
  return db.engine() == Engine::Sqlite
             ? "strftime('%Y-%m-%dT%H:%M:%fZ', 'now')"
             : "to_char(clock_timestamp() AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')";
}

const char* nowMsSql(const Connection& db) {
  return db.engine() == Engine::Sqlite ? "CAST((julianday('now') - 2440587.5) * 86400000 AS INTEGER)"
                                       : "CAST(extract(epoch FROM clock_timestamp()) * 1000 AS BIGINT)";
}

const char* skipLockedSql(const Connection& db) {
  return db.engine() == Engine::Sqlite ? "" : " FOR UPDATE SKIP LOCKED";
}

}  // namespace tally::store
