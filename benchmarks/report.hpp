// The figures of the read-latency benchmark, printed as a table or as JSON.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "http_timing.hpp"
#include "query_plans.hpp"
#include "synthetic_captures.hpp"

namespace tally::bench {

struct Machine {
  unsigned cores = 0;
  std::string cpu;                    // /proc/cpuinfo's model name
  std::string loadBefore, loadAfter;  // /proc/loadavg's 1, 5, 15 minute averages
};
Machine describeMachine();  // load before: now
std::string loadAverage();

struct DatabaseReport {
  std::string path;     // a file, or a PostgreSQL URL without its password
  bool filled = false;  // false: reused as found
  bool added = false;   // filled on top of the samples found (--reuse --add)
  FillStats fill;
  uint64_t bytes = 0;  // SQLite: database file and WAL, after a checkpoint; PostgreSQL: pg_database_size
  std::vector<std::pair<std::string, int64_t>> rows;      // table -> row count
  std::vector<std::pair<std::string, uint64_t>> largest;  // table or index -> bytes, largest first
};

struct RouteFigures {
  std::string route;
  int clients = 1;
  Summary summary;
  double storeMsPerRequest = 0;  // the store's statements, summed over every connection
};

struct RoutePlan {
  std::string route;
  double fullScanRowsPerRequest = 0;
  double vmStepsPerRequest = 0;  // PostgreSQL: shared buffers touched (found or read)
  std::vector<PlannedStatement> statements;
};

struct Report {
  bool postgres = false;  // the engine: PostgreSQL, else SQLite
  std::string engineVersion;
  // PostgreSQL: store ms and the statements per route come from
  // pg_stat_statements; when it cannot be read, why (and neither is shown).
  std::string serverStatementsMissing;
  Machine machine;
  DatabaseReport database;
  std::string server;  // "http://127.0.0.1:PORT/"
  size_t httpThreads = 0;
  std::vector<std::pair<std::string, double>> cold;  // route -> ms of a fresh server's first request
  std::vector<RouteFigures> figures;
  std::vector<RoutePlan> plans;
  size_t planProblems() const;
};

void printText(const Report& report);
void printJson(const Report& report);

}  // namespace tally::bench
