// Shared by the store's .cpp files; not part of its interface.
#pragma once

#include <exception>
#include <initializer_list>
#include <mutex>
#include <string>
#include <string_view>

#include "common/result.hpp"
#include "store/db.hpp"
#include "store/fault.hpp"
#include "store/store.hpp"

namespace tally::store::detail {

// One writer per process on SQLite: every write transaction holds this
// mutex. PostgreSQL takes concurrent writers (row locks and MVCC), so there
// it is not taken.
std::mutex& writeMutex();
class WriteLock {
 public:
  explicit WriteLock(const Connection& db) {
    if (db.engine() == Engine::Sqlite) lock_ = std::unique_lock(writeMutex());
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

// Runs body, turning exceptions (DbError, JSON errors, bad input) into an
// Error, and recording the store fault behind it, if any (lastFault()).
template <class T, class F>
Result<T> guarded(const char* what, F&& body) {
  setLastFault(Fault::kNone);
  try {
    return body();
  } catch (const std::exception& e) {
    setLastFault(faultOf(e));
    return makeError(std::string(what) + ": " + e.what());
  }
}

// Checks a Page's limit (1..1000) and cursor; the id to continue below, if any.
Result<std::optional<int64_t>> checkPage(const Page& page);

// Job rows: kJobColumns in this order, read by readJob.
inline constexpr const char* kJobColumns =
    "id, status, spec, progress_done, progress_total, progress_current, error, attempts, idempotency_key, "
    "created_at, started_at, finished_at, worker_pid, host, lease_expires_ms, max_attempts, attempt_errors, "
    "device_requirement";
Job readJob(const Statement& row);

// Leases (jobs.cpp). holdsLease: the job is running under `lease` (on
// PostgreSQL its row is then locked until the transaction ends).
// finishHeld: done | failed, counted on the host; inside the caller's
// transaction, after holdsLease. lostLease: why a lease no longer holds.
bool holdsLease(Connection* db, const Lease& lease);
void finishHeld(Connection* db, const Lease& lease, JobStatus status, const std::optional<std::string>& error);
std::string lostLease(Connection* db, const Lease& lease);

// A device's id, name, vendor, driver, api_version, features and info, in
// this order (a braced list reads them in order).
Device readDevice(RowReader& row);

// Run rows: runSelect(db, "WHERE ...") (+ ORDER BY ...), read by
// readRunRow; `where` names the runs through the alias r.
std::string runSelect(const Connection& db, std::string_view where);
RunRow readRunRow(const Statement& row);
// A run with its device, resources and ceilings (Runs::get), and its passes
// averaged over `samples` samples (Runs::passes), inside the caller's
// transaction: Runs::detail reads both in one.
std::optional<Run> readRun(Connection* db, int64_t runId);
std::vector<Pass> readRunPasses(Connection* db, int64_t runId, int samples);
// "WHERE"-less clause list for a RunFilter (" AND ..." each, positional "?"),
// and binding its values from parameter index `first`; returns the next index.
std::string runFilterSql(const RunFilter& filter);
// "?, ?, ..., ?": n parameters for an IN list (n >= 1); values are bound, never written into SQL.
std::string parameterList(size_t n);
int bindRunFilter(Statement& statement, const RunFilter& filter, int first);

// Each counters column and the pass's array that holds it on PostgreSQL
// (migration 0012), in the order ingest writes them.
struct CounterArray {
  std::string_view column, array;
};
inline constexpr CounterArray kCounterArrays[] = {
    {"resource", "counter_resources"}, {"kind", "counter_kinds"},     {"format", "counter_formats"},
    {"access", "counter_accesses"},    {"count", "counter_counts"},   {"bytes", "counter_bytes"},
    {"count_spread", "counter_spreads"}, {"source", "counter_sources"}, {"footprint_bytes", "counter_footprints"}};

// A pass's counters, where the engines keep them differently (migration
// 0012): rows of the counters table on SQLite; arrays on the pass's row on
// PostgreSQL, read here by unnesting only the arrays of the columns named,
// instead of through the counters view (which reads the pass again and
// every array). Both name the pass `p` and its counters `c`, with the
// counters table's column names; c.position orders them (0-based on
// SQLite, 1-based on PostgreSQL: use it to order, not as a value).
//
// After "FROM passes p": " JOIN counters c ON c.pass_id = p.id", or the
// arrays of p unnested as c.
std::string joinPassCounters(const Connection& db, std::initializer_list<std::string_view> columns);
// For a subquery over the counters of an outer query's pass p: "counters c
// WHERE c.pass_id = p.id", or "<p's arrays> AS c WHERE TRUE"; append
// " AND ..." for more conditions.
std::string countersOfPass(const Connection& db, std::initializer_list<std::string_view> columns);

}  // namespace tally::store::detail
