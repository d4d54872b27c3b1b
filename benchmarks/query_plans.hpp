// Which SQL the server runs for a request, how long its statements take, and
// what SQLite plans for them. An SQLite auto extension adds a profile trace to
// every connection the process opens afterwards, so the store's own
// statements are seen without touching the store.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.hpp"

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

}  // namespace tally::bench
