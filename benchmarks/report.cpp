#include "report.hpp"

#include <cstdio>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

namespace tally::bench {

using nlohmann::json;

namespace {

// Plans print the start of each statement: enough to tell them apart.
constexpr size_t kSqlShown = 110;

std::string shortened(const std::string& sql) {
  return sql.size() <= kSqlShown ? sql : sql.substr(0, kSqlShown) + " ...";
}

void printDatabase(const DatabaseReport& db, bool postgres) {
  std::printf("database: %s\n", db.path.c_str());
  if (db.filled) {
    std::printf(
        "  %s: %lld samples in %d captures in %.1f s (%.0f samples/s with making the captures); "
        "%.1f s in Store::ingestCapture: %.0f samples/s ingested\n",
        db.added ? "added to the samples found" : "filled", static_cast<long long>(db.fill.samples), db.fill.captures, db.fill.seconds,
        static_cast<double>(db.fill.samples) / db.fill.seconds, db.fill.ingestSeconds,
        db.fill.ingestSeconds > 0 ? static_cast<double>(db.fill.samples) / db.fill.ingestSeconds : 0.0);
    std::printf("  ingest CPU: %.1f s in this process", db.fill.ingestClientCpuSeconds);
    if (db.fill.ingestServerCpuSeconds >= 0) std::printf(", %.1f s in its PostgreSQL backend", db.fill.ingestServerCpuSeconds);
    std::printf("\n");
    if (postgres) {
      double total = db.fill.ingestSeconds + db.fill.statisticsWaitSeconds;
      std::printf("  with the statistics the ingests asked for (ANALYZE beside them): %.2f s more after the last, "
                  "%.0f samples/s ingested and analysed\n",
                  db.fill.statisticsWaitSeconds, total > 0 ? static_cast<double>(db.fill.samples) / total : 0.0);
    }
  } else {
    std::printf("  reused as found (--reuse)\n");
  }
  std::printf(
      "  size: %.1f MiB (%s)\n", static_cast<double>(db.bytes) / (1 << 20),
      postgres ? "pg_database_size: tables, indexes and TOAST" : "database and WAL after a checkpoint");
  std::printf("  rows:");
  for (const auto& [table, count] : db.rows)
    std::printf(" %s %lld", table.c_str(), static_cast<long long>(count));
  std::printf("\n");
  if (db.largest.empty()) return;
  std::printf("  largest (MiB):");
  for (const auto& [name, bytes] : db.largest)
    std::printf(" %s %.1f", name.c_str(), static_cast<double>(bytes) / (1 << 20));
  std::printf("\n");
}

void printFigures(const Report& report) {
  const std::vector<RouteFigures>& figures = report.figures;
  const bool storeTimed = !report.postgres || report.serverStatementsMissing.empty();
  std::printf("\n%-50s %7s %6s %8s %8s %8s %8s %8s %9s %9s\n", "route", "clients", "count", "p50 ms",
              "p90 ms", "p99 ms", "max ms", "req/s", "store ms", "KiB/resp");
  for (const auto& f : figures) {
    const Summary& s = f.summary;
    char storeMs[32] = "        -";
    if (storeTimed) std::snprintf(storeMs, sizeof storeMs, "%9.2f", f.storeMsPerRequest);
    std::printf("%-50s %7d %6zu %8.2f %8.2f %8.2f %8.2f %8.1f %s %9.1f\n", f.route.c_str(), f.clients,
                s.count, s.p50, s.p90, s.p99, s.max, s.perSecond, storeMs, s.meanBytes / 1024);
    if (s.errors) std::printf("  FAILED %zu times, first: %s\n", s.errors, s.firstError.c_str());
  }
  if (!report.postgres) {
    std::printf(
        "(store ms: per request, the store's SQLite statements from first step to finalize, rows read\n"
        " into structs included, summed over the server's threads; SQLite's profile clock ticks in whole "
        "ms,\n"
        " so this is a mean over many requests)\n");
  } else if (storeTimed) {
    std::printf(
        "(store ms: per request, the server's execution time of the store's statements (pg_stat_statements\n"
        " total_exec_time, BEGIN and COMMIT included), summed over the connections; round trips, planning "
        "and\n"
        " reading rows into structs are not in it, unlike SQLite's figure)\n");
  } else {
    std::printf("(store ms: not measured: pg_stat_statements cannot be read: %s)\n",
                report.serverStatementsMissing.c_str());
  }
}

// PostgreSQL: each route's SELECTs with what pg_stat_statements counted for one request.
void printServerStatements(const Report& report) {
  if (!report.serverStatementsMissing.empty()) {
    std::printf("\nstatements per route: not shown: pg_stat_statements cannot be read: %s\n",
                report.serverStatementsMissing.c_str());
    return;
  }
  std::printf(
      "\nstatements per route (pg_stat_statements over one request, or one walk), then the EXPLAIN of each\n"
      " SELECT with the values it ran with, and its generic plan:\n");
  for (const auto& plan : report.plans) {
    std::printf("%s  [per request: %.0f shared buffers touched]\n", plan.route.c_str(),
                plan.vmStepsPerRequest);
    for (const auto& statement : plan.statements) {
      std::printf("  %s\n", shortened(statement.sql).c_str());
      for (const auto& line : statement.plan) std::printf("      %s\n", line.c_str());
      for (const auto& problem : statement.problems) std::printf("    PROBLEM: %s\n", problem.c_str());
    }
  }
  size_t problems = report.planProblems();
  if (problems == 0) {
    std::printf("query plans: ok (no sequential scan of runs, samples, passes, counters, run_resources or\n"
                " screenshots, in the plans for the values run nor in the generic plans)\n");
  } else {
    std::printf("query plans: %zu problems\n", problems);
  }
}

void printPlans(const Report& report) {
  if (report.postgres) {
    printServerStatements(report);
    return;
  }
  std::printf("\nquery plans (EXPLAIN QUERY PLAN of every SELECT a route runs):\n");
  for (const auto& plan : report.plans) {
    std::printf("%s  [per request: %.0f rows stepped in full scans, %.0f SQLite VM steps]\n",
                plan.route.c_str(), plan.fullScanRowsPerRequest, plan.vmStepsPerRequest);
    for (const auto& statement : plan.statements) {
      std::printf("  %s\n", shortened(statement.sql).c_str());
      for (const auto& line : statement.plan) std::printf("      %s\n", line.c_str());
      for (const auto& problem : statement.problems) std::printf("    PROBLEM: %s\n", problem.c_str());
    }
  }
  size_t problems = report.planProblems();
  if (problems == 0) {
    std::printf(
        "query plans: ok (no scan of samples, passes, counters, run_resources or screenshots; no automatic\n"
        " index; no sort of rows with correlated subqueries before LIMIT)\n");
  } else {
    std::printf("query plans: %zu problems\n", problems);
  }
}

json summaryJson(const RouteFigures& f) {
  const Summary& s = f.summary;
  return {{"route", f.route},
          {"clients", f.clients},
          {"count", s.count},
          {"p50_ms", s.p50},
          {"p90_ms", s.p90},
          {"p99_ms", s.p99},
          {"max_ms", s.max},
          {"requests_per_s", s.perSecond},
          {"errors", s.errors},
          {"store_ms_per_request", f.storeMsPerRequest},
          {"mean_response_bytes", s.meanBytes}};
}

std::string firstLine(const char* path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

}  // namespace

std::string loadAverage() {
  std::string line = firstLine("/proc/loadavg");  // "0.52 0.58 0.59 1/467 12345"
  size_t end = 0;
  for (int field = 0; field < 3 && end != std::string::npos; ++field) end = line.find(' ', end + (field > 0));
  return line.substr(0, end);
}

Machine describeMachine() {
  Machine m;
  m.cores = std::thread::hardware_concurrency();
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) != 0) continue;
    m.cpu = line.substr(line.find(':') + 2);
    break;
  }
  m.loadBefore = loadAverage();
  return m;
}

size_t Report::planProblems() const {
  size_t n = 0;
  for (const auto& plan : plans) {
    for (const auto& statement : plan.statements) n += statement.problems.size();
  }
  return n;
}

void printText(const Report& report) {
  const Machine& m = report.machine;
  std::printf("Tally read latency (REST API)\n");
  std::printf("machine: %u cores, %s; load average (1, 5, 15 min) %s as timing began, %s as it ended\n",
              m.cores, m.cpu.c_str(), m.loadBefore.c_str(), m.loadAfter.c_str());
  std::printf("engine: %s\n", report.engineVersion.c_str());
  printDatabase(report.database, report.postgres);
  std::printf(
      "server: %s (%zu HTTP threads, a read-only %s connection per thread, one request per connection)\n",
      report.server.c_str(), report.httpThreads, report.postgres ? "PostgreSQL" : "SQLite");
  for (const auto& [route, ms] : report.cold) {
    std::printf("cold first request: %s: %.2f ms (%s)\n", route.c_str(), ms,
                report.postgres
                    ? "fresh server, its connections opened then; PostgreSQL's caches are not dropped"
                    : "fresh server, database file out of the OS page cache");
  }
  if (!report.postgres) {
    std::printf("then the database file is read once into the page cache; the timings below are warm\n");
  }
  printFigures(report);
  printPlans(report);
}

void printJson(const Report& report) {
  const DatabaseReport& db = report.database;
  json rows = json::object();
  for (const auto& [table, count] : db.rows) rows[table] = count;
  json largest = json::object();
  for (const auto& [name, bytes] : db.largest) largest[name] = bytes;
  json database = {
      {"path", db.path}, {"filled", db.filled}, {"added", db.added}, {"bytes", db.bytes}, {"rows", rows}, {"largest", largest}};
  if (db.filled) {
    database["fill"] = {{"samples", db.fill.samples},
                        {"captures", db.fill.captures},
                        {"seconds", db.fill.seconds},
                        {"ingest_seconds", db.fill.ingestSeconds},
                        {"ingest_client_cpu_seconds", db.fill.ingestClientCpuSeconds},
                        {"statistics_wait_seconds", db.fill.statisticsWaitSeconds},
                        {"ingest_server_cpu_seconds", db.fill.ingestServerCpuSeconds < 0 ? nlohmann::json(nullptr)
                                                                                           : nlohmann::json(db.fill.ingestServerCpuSeconds)}};
  }
  json cold = json::array();
  for (const auto& [route, ms] : report.cold) cold.push_back({{"route", route}, {"ms", ms}});
  json figures = json::array();
  for (const auto& f : report.figures) figures.push_back(summaryJson(f));
  json plans = json::array();
  for (const auto& plan : report.plans) {
    json statements = json::array();
    for (const auto& s : plan.statements) {
      statements.push_back({{"sql", s.sql}, {"plan", s.plan}, {"problems", s.problems}});
    }
    plans.push_back({{"route", plan.route},
                     {"full_scan_rows_per_request", plan.fullScanRowsPerRequest},
                     {"vm_steps_per_request", plan.vmStepsPerRequest},
                     {"statements", statements}});
  }
  const Machine& m = report.machine;
  json machine = {
      {"cores", m.cores}, {"cpu", m.cpu}, {"load_before", m.loadBefore}, {"load_after", m.loadAfter}};
  json out = {{"engine", report.postgres ? "postgresql" : "sqlite"},
              {"engine_version", report.engineVersion},
              {"machine", machine},
              {"database", database},
              {"server", {{"url", report.server}, {"http_threads", report.httpThreads}}},
              {"cold_first_requests", cold},
              {"routes", figures},
              {"plans", plans},
              {"plan_problems", report.planProblems()},
              // PostgreSQL: store ms and the statements per route need pg_stat_statements.
              {"store_ms_measured", !report.postgres || report.serverStatementsMissing.empty()},
              {"plans_checked", !report.postgres || report.serverStatementsMissing.empty()}};
  std::printf("%s\n", out.dump(2).c_str());
}

}  // namespace tally::bench
