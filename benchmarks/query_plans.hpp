// Which SQL the server runs for a request, how long its statements take, and
// what SQLite plans for them. An SQLite auto extension adds a profile trace to
// every connection the process opens afterwards, so the store's own
// statements are seen without touching the store. On PostgreSQL the same
// questions go to the server's pg_stat_statements view (ServerStatements).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "store/db.hpp"

namespace tally::bench {

// Call before the connections to watch are opened.
void installStatementTrace();

// Over every traced connection since installStatementTrace().
struct StatementTotals {
  uint64_t statements = 0;
  uint64_t nanoseconds = 0;  // first step to reset or finalize: SQLite's time and the caller's between steps
  uint64_t fullScanSteps = 0;  // rows stepped through in full table scans
  uint64_t vmSteps = 0;        // virtual machine steps: the work done, whatever the plan
};
StatementTotals statementTotals();

// Collects the distinct SQL text (parameters as ?) of statements that finish
// between the two calls, in the order they first finish.
void startRecording();
std::vector<std::string> stopRecording();

struct PlannedStatement {
  std::string sql;
  std::vector<std::string> plan;      // EXPLAIN QUERY PLAN, indented by depth
  std::vector<std::string> problems;  // empty: every large table is searched through an index
};

// EXPLAIN QUERY PLAN of each SELECT among `sqls` on a read-only connection to
// `dbPath`. Problems: a scan of a table that grows with the samples (samples,
// passes, counters, run_resources, screenshots); an automatic index, which
// SQLite builds for one statement where an index is missing; and a sort of
// the whole selection in a statement with correlated subqueries, which then
// run for every selected row, not only for those LIMIT keeps.
Result<std::vector<PlannedStatement>> explain(const std::string& dbPath,
                                              const std::vector<std::string>& sqls);

// PostgreSQL: records the statements (their "$N" text and parameter values)
// that this process's store connections execute between the two calls, one
// per distinct text, in the order first run.
struct RecordedStatement {
  std::string sql;
  std::vector<std::optional<std::string>> parameters;
};
void startRecordingPostgres();
std::vector<RecordedStatement> stopRecordingPostgres();

// EXPLAIN of each recorded SELECT on a connection of its own to `url`, with
// the values it ran with: the plan chosen for those values (plan_cache_mode =
// force_custom_plan) and the generic plan a prepared statement may switch to
// after five runs (force_generic_plan). Problems: a sequential scan of runs
// or of a table that grows with the samples, in either plan.
Result<std::vector<PlannedStatement>> explainPostgres(const std::string& url,
                                                      const std::vector<RecordedStatement>& statements);

// PostgreSQL: what the server's pg_stat_statements view counts for one
// database, every connection to it included, read over a connection of its
// own. Available when the server loads the module (shared_preload_libraries)
// and the database has the extension (CREATE EXTENSION pg_stat_statements);
// the benchmark creates nothing.
class ServerStatements {
 public:
  // Null, with the reason in `why`, when the view cannot be read.
  static std::unique_ptr<ServerStatements> connect(const std::string& url, std::string* why);

  struct Entry {
    std::string query;  // normalised: constants and parameters as $N
    int64_t calls = 0;
    double ms = 0;  // total_exec_time: on the server, planning, round trips and the client's reading excluded
    int64_t rows = 0;
    int64_t blocksHit = 0, blocksRead = 0;  // shared buffers found in PostgreSQL's cache, and read into it
  };
  using Snapshot = std::map<std::string, Entry>;  // by queryid
  Snapshot snapshot();  // the view's statements, without the benchmark's own reads of it
  // after - before, per statement; statements not called in between left out.
  static Snapshot difference(const Snapshot& before, const Snapshot& after);
  static Entry total(const Snapshot& statements);

 private:
  explicit ServerStatements(std::unique_ptr<store::Connection> db) : db_(std::move(db)) {}
  std::unique_ptr<store::Connection> db_;
};

}  // namespace tally::bench
