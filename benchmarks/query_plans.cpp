#include "query_plans.hpp"

#include <sqlite3.h>

#include <atomic>
#include <cctype>
#include <map>
#include <mutex>
#include <regex>
#include <set>

namespace tally::bench {
namespace {

struct Trace {
  std::atomic<uint64_t> statements{0}, nanoseconds{0}, fullScanSteps{0}, vmSteps{0};
  std::atomic<bool> recording{false};
  std::mutex mutex;  // guards seen and sqls
  std::set<std::string> seen;
  std::vector<std::string> sqls;  // in the order first run
};

Trace& trace() {
  static Trace t;
  return t;
}

int onStatementEnd(unsigned type, void*, void* statement, void* nanoseconds) {
  if (type != SQLITE_TRACE_PROFILE) return 0;
  auto* stmt = static_cast<sqlite3_stmt*>(statement);
  Trace& t = trace();
  t.statements += 1;
  t.nanoseconds += *static_cast<sqlite3_uint64*>(nanoseconds);
  t.fullScanSteps += static_cast<uint64_t>(sqlite3_stmt_status(stmt, SQLITE_STMTSTATUS_FULLSCAN_STEP, 1));
  t.vmSteps += static_cast<uint64_t>(sqlite3_stmt_status(stmt, SQLITE_STMTSTATUS_VM_STEP, 1));
  if (t.recording) {
    std::lock_guard lock(t.mutex);
    if (t.seen.insert(sqlite3_sql(stmt)).second) t.sqls.push_back(sqlite3_sql(stmt));
  }
  return 0;
}

int traceConnection(sqlite3* db, const char**, const sqlite3_api_routines*) {
  sqlite3_trace_v2(db, SQLITE_TRACE_PROFILE, onStatementEnd, nullptr);
  return SQLITE_OK;
}

bool isSelect(const std::string& sql) {
  size_t start = sql.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return false;
  std::string head = sql.substr(start, 6);
  for (char& c : head) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return head == "SELECT" || head.rfind("WITH", 0) == 0;
}

// Table names by the names a plan uses for them (their aliases, and
// themselves). An alias given to two tables in one statement keeps the last.
std::map<std::string, std::string> tablesByAlias(const std::string& sql) {
  static const std::regex kSource(R"(\b(?:FROM|JOIN)\s+([A-Za-z_]\w*)(?:\s+(?:AS\s+)?([A-Za-z_]\w*))?)",
                                  std::regex::icase);
  static const std::set<std::string> kKeywords = {"WHERE",   "JOIN",  "ON",    "LEFT",  "INNER",
                                                  "CROSS",   "GROUP", "ORDER", "LIMIT", "USING",
                                                  "NATURAL", "AND",   "OR",    "UNION"};
  std::map<std::string, std::string> out;
  for (std::sregex_iterator it(sql.begin(), sql.end(), kSource), end; it != end; ++it) {
    std::string table = (*it)[1], alias = (*it)[2];
    out[table] = table;
    std::string upper = alias;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (!alias.empty() && !kKeywords.count(upper)) out[alias] = table;
  }
  return out;
}

std::vector<std::string> problemsOf(const std::string& detail,
                                    const std::map<std::string, std::string>& tables) {
  static const std::set<std::string> kLarge = {"samples", "passes", "counters", "run_resources",
                                               "screenshots"};
  std::vector<std::string> out;
  if (detail.rfind("SCAN ", 0) == 0) {
    std::string name = detail.substr(5, detail.find(' ', 5) - 5);
    auto it = tables.find(name);
    std::string table = it == tables.end() ? name : it->second;
    if (kLarge.count(table)) out.push_back("scans " + table + ": " + detail);
  }
  if (detail.find("AUTOMATIC") != std::string::npos) out.push_back("automatic index: " + detail);
  return out;
}

Result<PlannedStatement> explainOne(sqlite3* db, const std::string& sql) {
  PlannedStatement planned{sql, {}, {}};
  sqlite3_stmt* stmt = nullptr;
  std::string query = "EXPLAIN QUERY PLAN " + sql;
  if (sqlite3_prepare_v2(db, query.c_str(), -1, &stmt, nullptr) != SQLITE_OK) {
    std::string message = sqlite3_errmsg(db);
    sqlite3_finalize(stmt);
    return makeError("EXPLAIN QUERY PLAN: " + message + ": " + sql);
  }
  auto tables = tablesByAlias(sql);
  std::map<int, int> depth;  // plan node id -> depth; a node's parent comes before it
  bool sortsAll = false, correlated = false;
  while (sqlite3_step(stmt) == SQLITE_ROW) {
    int id = sqlite3_column_int(stmt, 0);
    int parent = sqlite3_column_int(stmt, 1);
    std::string detail = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 3));
    depth[id] = depth.count(parent) ? depth[parent] + 1 : 0;
    planned.plan.push_back(std::string(2 * static_cast<size_t>(depth[id]), ' ') + detail);
    for (auto& problem : problemsOf(detail, tables)) planned.problems.push_back(std::move(problem));
    if (depth[id] == 0) {
      sortsAll = sortsAll || detail == "USE TEMP B-TREE FOR ORDER BY";
      correlated = correlated || detail.rfind("CORRELATED SCALAR SUBQUERY", 0) == 0;
    }
  }
  sqlite3_finalize(stmt);
  // SQLite computes every result column before it sorts, so the subqueries
  // run for each selected row, however few rows LIMIT then keeps.
  if (sortsAll && correlated) {
    planned.problems.push_back("sorts every selected row with its correlated subqueries before LIMIT");
  }
  return planned;
}

}  // namespace

void installStatementTrace() { sqlite3_auto_extension(reinterpret_cast<void (*)()>(traceConnection)); }

StatementTotals statementTotals() {
  const Trace& t = trace();
  return {t.statements, t.nanoseconds, t.fullScanSteps, t.vmSteps};
}

void startRecording() {
  Trace& t = trace();
  std::lock_guard lock(t.mutex);
  t.seen.clear();
  t.sqls.clear();
  t.recording = true;
}

std::vector<std::string> stopRecording() {
  Trace& t = trace();
  t.recording = false;
  std::lock_guard lock(t.mutex);
  return t.sqls;
}

Result<std::vector<PlannedStatement>> explain(const std::string& dbPath,
                                              const std::vector<std::string>& sqls) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(dbPath.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    std::string message = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return makeError(dbPath + ": " + message);
  }
  std::vector<PlannedStatement> out;
  for (const auto& sql : sqls) {
    if (!isSelect(sql)) continue;  // BEGIN, COMMIT, PRAGMA
    auto planned = explainOne(db, sql);
    if (!planned) {
      sqlite3_close(db);
      return makeError(planned.error());
    }
    out.push_back(std::move(*planned));
  }
  sqlite3_close(db);
  return out;
}

namespace {

struct PostgresRecording {
  std::mutex mutex;
  std::set<std::string> seen;
  std::vector<RecordedStatement> statements;
};

PostgresRecording& postgresRecording() {
  static PostgresRecording r;
  return r;
}

// A parameter's text as an SQL literal (standard_conforming_strings: only quotes double).
std::string literal(const std::optional<std::string>& value) {
  if (!value) return "NULL";
  std::string out = "'";
  for (char c : *value) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

std::vector<std::string> postgresProblems(const std::string& line) {
  static const std::regex kSeqScan(R"(Seq Scan on (\w+))");
  static const std::set<std::string> kLarge = {"runs", "samples", "passes", "counters", "run_resources",
                                               "screenshots"};
  std::smatch match;
  if (std::regex_search(line, match, kSeqScan) && kLarge.count(match[1])) {
    return {"sequential scan of " + std::string(match[1]) + ": " + line};
  }
  return {};
}

}  // namespace

void startRecordingPostgres() {
  PostgresRecording& r = postgresRecording();
  {
    std::lock_guard lock(r.mutex);
    r.seen.clear();
    r.statements.clear();
  }
  store::observePostgresStatements([&r](const std::string& sql, const std::vector<std::optional<std::string>>& p) {
    std::lock_guard lock(r.mutex);
    if (r.seen.insert(sql).second) r.statements.push_back({sql, p});
  });
}

std::vector<RecordedStatement> stopRecordingPostgres() {
  store::observePostgresStatements({});
  PostgresRecording& r = postgresRecording();
  std::lock_guard lock(r.mutex);
  return r.statements;
}

Result<std::vector<PlannedStatement>> explainPostgres(const std::string& url,
                                                      const std::vector<RecordedStatement>& statements) {
  std::vector<PlannedStatement> out;
  try {
    auto db = store::openPostgres(url);
    for (const auto& recorded : statements) {
      if (!isSelect(recorded.sql)) continue;
      db->exec("PREPARE tally_explain AS " + recorded.sql);
      std::string arguments;
      for (const auto& value : recorded.parameters) arguments += (arguments.empty() ? "" : ", ") + literal(value);
      PlannedStatement planned{recorded.sql, {}, {}};
      for (const char* mode : {"force_custom_plan", "force_generic_plan"}) {
        db->exec(std::string("SET plan_cache_mode = ") + mode);
        planned.plan.push_back(std::string(mode == std::string("force_custom_plan") ? "plan for these values:"
                                                                                     : "generic plan:"));
        store::Statement explain(*db, "EXPLAIN EXECUTE tally_explain" +
                                          (arguments.empty() ? std::string() : "(" + arguments + ")"));
        while (explain.step()) {
          std::string line = explain.getText(0);
          for (auto& problem : postgresProblems(line)) planned.problems.push_back(std::move(problem));
          planned.plan.push_back("  " + line);
        }
      }
      db->exec("DEALLOCATE tally_explain; RESET plan_cache_mode");
      out.push_back(std::move(planned));
    }
  } catch (const std::exception& e) {
    return makeError(std::string("EXPLAIN on PostgreSQL: ") + e.what());
  }
  return out;
}

std::unique_ptr<ServerStatements> ServerStatements::connect(const std::string& url, std::string* why) {
  try {
    auto db = store::openPostgres(url);
    {
      store::Statement installed(*db,
                                 "SELECT COUNT(*) FROM pg_extension WHERE extname = 'pg_stat_statements'");
      installed.step();
      if (installed.getInt(0) == 0) {
        if (why) *why = "the database has no pg_stat_statements extension";
        return nullptr;
      }
      installed.run();
    }
    std::unique_ptr<ServerStatements> out(new ServerStatements(std::move(db)));
    out->snapshot();  // fails when the server does not load the module
    return out;
  } catch (const std::exception& e) {
    if (why) *why = e.what();
    return nullptr;
  }
}

ServerStatements::Snapshot ServerStatements::snapshot() {
  store::Statement query(*db_,
                         "SELECT queryid::text, query, calls, total_exec_time, rows, shared_blks_hit, "
                         "shared_blks_read FROM pg_stat_statements WHERE dbid = (SELECT oid FROM pg_database "
                         "WHERE datname = current_database()) AND queryid IS NOT NULL AND query NOT LIKE "
                         "'%pg_stat_statements%'");
  Snapshot out;
  while (query.step()) {
    Entry& e = out[query.getText(0)];
    e.query = query.getText(1);
    e.calls += query.getInt(2);
    e.ms += query.getDouble(3);
    e.rows += query.getInt(4);
    e.blocksHit += query.getInt(5);
    e.blocksRead += query.getInt(6);
  }
  return out;
}

ServerStatements::Snapshot ServerStatements::difference(const Snapshot& before, const Snapshot& after) {
  Snapshot out;
  for (const auto& [id, a] : after) {
    Entry d = a;
    if (auto it = before.find(id); it != before.end()) {
      d.calls -= it->second.calls;
      d.ms -= it->second.ms;
      d.rows -= it->second.rows;
      d.blocksHit -= it->second.blocksHit;
      d.blocksRead -= it->second.blocksRead;
    }
    if (d.calls > 0) out[id] = d;
  }
  return out;
}

ServerStatements::Entry ServerStatements::total(const Snapshot& statements) {
  Entry t;
  for (const auto& [id, e] : statements) {
    t.calls += e.calls;
    t.ms += e.ms;
    t.rows += e.rows;
    t.blocksHit += e.blocksHit;
    t.blocksRead += e.blocksRead;
  }
  return t;
}

}  // namespace tally::bench
