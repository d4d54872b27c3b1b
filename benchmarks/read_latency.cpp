// tally_bench_read_latency: how fast the REST API reads with N samples stored
// (docs/benchmarks.md). Fills a fresh database through Store::ingestCapture
// (the daemon's path after a capture), serves it with the daemon's HTTP
// server and service routes in this process, and times the read routes with
// one client and with several at once. The database is a SQLite file or a
// PostgreSQL database (--db postgresql://...). It prints figures and asserts
// none; it exits 1 when a request fails.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>

#include "api/builtin_routes.hpp"
#include "api/http_server.hpp"
#include "bench_database.hpp"
#include "http_timing.hpp"
#include "query_plans.hpp"
#include "renderers/renderer.hpp"
#include "report.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace tally::bench {
namespace {

namespace fs = std::filesystem;

constexpr int kPageLimit = 1000;  // the API's largest page: the deepest walk per request
constexpr int kListLimit = 50;    // a dashboard's page

struct Options {
  int64_t samples = 100000;
  size_t requests = 1000;  // per route and client count (pages for the walk)
  int clients = 8;
  int seconds = 30;  // per route and client count: no request starts later
  std::string db;    // a file or a postgresql:// URL; empty: a temporary file, removed at the end
  bool reuse = false;
  int64_t add = 0;  // with reuse: samples ingested into the database first
  bool json = false;
  std::string templatePath = TALLY_BENCH_TEMPLATE;
  std::string route;  // only the routes whose name holds this text; empty: all
};

// ---- workloads ---------------------------------------------------------------

template <class T>
const T& pick(const std::vector<T>& values, std::mt19937& random) {
  return values[std::uniform_int_distribution<size_t>(0, values.size() - 1)(random)];
}

// A query value as a URL carries it: everything but unreserved characters as %XX.
std::string percentEncoded(const std::string& value) {
  std::string out;
  for (unsigned char c : value) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      out += static_cast<char>(c);
    } else {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", c);
      out += hex;
    }
  }
  return out;
}

using PathMaker = std::function<std::string(std::mt19937&)>;

Workload oneRequest(PathMaker path) {
  return [path](HttpClient& client, std::mt19937& random) {
    UnitResult unit;
    auto answer = client.get(path(random));
    if (answer) {
      unit.ms.push_back(answer->ms);
      unit.bytes += answer->bytes;
    } else {
      unit.error = answer.error();
    }
    return unit;
  };
}

// Every page of GET /api/runs, newest first, as a client walks the listing.
Workload walkAllRuns(size_t maxPages) {
  return [maxPages](HttpClient& client, std::mt19937&) {
    UnitResult unit;
    std::string cursor;
    for (size_t page = 0; page < maxPages; ++page) {
      std::string path =
          "/api/runs?limit=" + std::to_string(kPageLimit) + (cursor.empty() ? "" : "&cursor=" + cursor);
      std::string body;
      auto answer = client.get(path, &body);
      if (!answer) {
        unit.error = answer.error();
        return unit;
      }
      unit.ms.push_back(answer->ms);
      unit.bytes += answer->bytes;
      auto listing = nlohmann::json::parse(body, nullptr, false);
      if (!listing.is_object()) {
        unit.error = path + ": the answer is not a JSON object";
        return unit;
      }
      const auto& next = listing["next_cursor"];
      if (!next.is_string()) return unit;  // null: the last page
      cursor = next.get<std::string>();
    }
    unit.error = "the walk did not end within " + std::to_string(maxPages) + " pages";
    return unit;
  };
}

struct RouteBench {
  std::string route;
  Workload workload;
  size_t requestsPerUnit = 1;
};

std::vector<RouteBench> routeBenches(const Pools& pools) {
  auto id = [](int64_t v) { return std::to_string(v); };
  auto runsWhere = [](const std::string& filter) {
    return "/api/runs?" + filter + (filter.empty() ? "" : "&") + "limit=" + std::to_string(kListLimit);
  };
  size_t pages = (pools.runs.size() + kPageLimit - 1) / kPageLimit;
  return {
      {"GET /api/runs?limit=50", oneRequest([=](std::mt19937&) { return runsWhere(""); })},
      {"GET /api/runs?renderer=R&limit=50", oneRequest([=, &pools](std::mt19937& r) {
         return runsWhere("renderer=" + pick(pools.renderers, r));
       })},
      {"GET /api/runs?width=W&height=H&limit=50", oneRequest([=, &pools](std::mt19937& r) {
         auto [w, h] = pick(pools.resolutions, r);
         return runsWhere("width=" + id(w) + "&height=" + id(h));
       })},
      {"GET /api/runs?device=D&limit=50", oneRequest([=, &pools](std::mt19937& r) {
         return runsWhere("device=" + id(pick(pools.devices, r)));
       })},
      {"GET /api/runs?device=NAME&limit=50", oneRequest([=, &pools](std::mt19937& r) {
         return runsWhere("device=" + percentEncoded(pick(pools.deviceNames, r)));
       })},
      {"GET /api/runs?scene=S&limit=50", oneRequest([=, &pools](std::mt19937& r) {
         return runsWhere("scene=" + percentEncoded(pick(pools.scenes, r)));
       })},
      {"GET /api/runs?capture=C&limit=50", oneRequest([=, &pools](std::mt19937& r) {
         return runsWhere("capture=" + id(pick(pools.captures, r)));
       })},
      {"GET /api/runs?limit=1000 (every page, to the end)", walkAllRuns(pages + 1), pages},
      {"GET /api/runs/{id}",
       oneRequest([=, &pools](std::mt19937& r) { return "/api/runs/" + id(pick(pools.runs, r)); })},
      {"GET /api/runs/{id}/samples", oneRequest([=, &pools](std::mt19937& r) {
         return "/api/runs/" + id(pick(pools.runs, r)) + "/samples";
       })},
      {"GET /api/samples/{id}",
       oneRequest([=, &pools](std::mt19937& r) { return "/api/samples/" + id(pick(pools.samples, r)); })},
  };
}

// ---- measuring -------------------------------------------------------------------

// Where the store's statement figures come from: SQLite's trace of this
// process's connections, or the PostgreSQL server's pg_stat_statements (null
// when it cannot be read: no store ms then).
struct StatementSource {
  bool postgres = false;
  std::unique_ptr<ServerStatements> server;
  // Milliseconds spent in the store's statements so far, over every connection.
  double storeMs() {
    if (!postgres) return static_cast<double>(statementTotals().nanoseconds) / 1e6;
    return server ? ServerStatements::total(server->snapshot()).ms : 0;
  }
};

RouteFigures timeRoute(int port, const Options& options, const RouteBench& bench, int clients,
                       StatementSource& source) {
  // Units of work: requests, or whole walks for the paginated listing (at
  // least one per client).
  size_t units = (options.requests + bench.requestsPerUnit - 1) / bench.requestsPerUnit;
  if (bench.requestsPerUnit > 1) units = std::max<size_t>(units, static_cast<size_t>(clients));
  double before = source.storeMs();
  Summary summary = measure(port, clients, units, std::chrono::seconds(options.seconds), bench.workload);
  double after = source.storeMs();
  double storeMs = summary.count ? (after - before) / static_cast<double>(summary.count) : 0;
  return RouteFigures{bench.route, clients, summary, storeMs};
}

// PostgreSQL: the SELECTs one request (or one walk) of the route ran, with
// what the server counted for them, most time first.
Result<RoutePlan> serverStatementsOf(int port, const std::string& url, ServerStatements& server,
                                     const RouteBench& bench) {
  HttpClient client(port);
  std::mt19937 random(7);
  auto before = server.snapshot();
  startRecordingPostgres();
  UnitResult unit = bench.workload(client, random);
  auto recorded = stopRecordingPostgres();
  auto ran = ServerStatements::difference(before, server.snapshot());
  if (!unit.error.empty()) return makeError(unit.error);
  double requests = static_cast<double>(std::max<size_t>(1, unit.ms.size()));
  auto total = ServerStatements::total(ran);
  RoutePlan plan{bench.route, 0, static_cast<double>(total.blocksHit + total.blocksRead) / requests, {}};
  std::vector<ServerStatements::Entry> selects;
  for (const auto& [id, e] : ran) {
    size_t start = e.query.find_first_not_of(" \t\r\n");
    if (start != std::string::npos &&
        (e.query.compare(start, 6, "SELECT") == 0 || e.query.compare(start, 4, "WITH") == 0)) {
      selects.push_back(e);
    }
  }
  std::sort(selects.begin(), selects.end(), [](const auto& a, const auto& b) { return a.ms > b.ms; });
  for (const auto& e : selects) {
    char line[200];
    std::snprintf(
        line, sizeof line,
        "per request: %.1f calls, %.3f ms, %.0f rows, %.0f shared buffers (%.0f read into the cache)",
        static_cast<double>(e.calls) / requests, e.ms / requests, static_cast<double>(e.rows) / requests,
        static_cast<double>(e.blocksHit + e.blocksRead) / requests,
        static_cast<double>(e.blocksRead) / requests);
    plan.statements.push_back(PlannedStatement{e.query, {line}, {}});
  }
  // The plans of the statements as they ran, with their values.
  auto explained = explainPostgres(url, recorded);
  if (!explained) return makeError(explained.error());
  for (auto& statement : *explained) plan.statements.push_back(std::move(statement));
  return plan;
}

Result<RoutePlan> planRoute(int port, const std::string& dbPath, const RouteBench& bench) {
  HttpClient client(port);
  std::mt19937 random(7);
  StatementTotals before = statementTotals();
  startRecording();
  UnitResult unit = bench.workload(client, random);
  auto sqls = stopRecording();
  StatementTotals after = statementTotals();
  if (!unit.error.empty()) return makeError(unit.error);
  auto statements = explain(dbPath, sqls);
  if (!statements) return makeError(statements.error());
  double requests = static_cast<double>(std::max<size_t>(1, unit.ms.size()));
  return RoutePlan{bench.route, static_cast<double>(after.fullScanSteps - before.fullScanSteps) / requests,
                   static_cast<double>(after.vmSteps - before.vmSteps) / requests, std::move(*statements)};
}

// The daemon's HTTP server and service routes, built as `tallyd serve`
// builds them, without the capture worker: nothing is queued while reads are
// timed. On the heap: the routes hold on to the context.
struct Daemon {
  service::ServiceContext context;
  std::unique_ptr<api::HttpServer> server;
  size_t threads = 0;
};

Result<std::unique_ptr<Daemon>> startDaemon(store::Store& writer, const std::string& path) {
  auto daemon = std::make_unique<Daemon>();
  daemon->context.writer = &writer;
  daemon->context.dbPath = path;
  daemon->context.rendererNames = renderers::rendererNames();
  api::Router router;
  api::addBuiltinRoutes(router, renderers::rendererNames());
  service::addServiceRoutes(router, daemon->context);
  api::ServerOptions options;
  options.bindAddress = "127.0.0.1";
  options.port = 0;
  daemon->threads = options.threads;
  auto server = api::HttpServer::create(options, std::move(router));
  if (!server) return makeError(server.error());
  daemon->server = std::move(*server);
  daemon->server->start();
  return daemon;
}

// The first requests of a fresh server (whose threads open their read
// connections on first use), each with the file out of the page cache.
Result<std::vector<std::pair<std::string, double>>> timeColdRequests(int port, const std::string& path,
                                                                     const Pools& pools) {
  std::vector<std::pair<std::string, std::string>> firsts = {
      {"GET /api/runs?limit=50", "/api/runs?limit=50"},
      {"GET /api/samples/{id}", "/api/samples/" + std::to_string(pools.samples[pools.samples.size() / 2])}};
  std::vector<std::pair<std::string, double>> out;
  for (const auto& [route, target] : firsts) {
    evictFromPageCache(path);
    auto answer = HttpClient(port).get(target);
    if (!answer) return makeError(answer.error());
    out.emplace_back(route, answer->ms);
  }
  return out;
}

std::vector<RouteFigures> timeRoutes(int port, const Options& options, const std::vector<RouteBench>& benches,
                                     size_t httpThreads, StatementSource& source) {
  // Every server thread opens its read connection before timing starts.
  measure(port, options.clients, 4 * httpThreads, std::chrono::seconds(options.seconds),
          oneRequest([](std::mt19937&) { return "/api/runs?limit=1"; }));
  std::vector<RouteFigures> out;
  for (int clients : {1, options.clients}) {
    for (const auto& bench : benches) {
      if (!options.json) std::fprintf(stderr, "timing %s with %d client(s)\n", bench.route.c_str(), clients);
      out.push_back(timeRoute(port, options, bench, clients, source));
    }
  }
  return out;
}

int fail(const std::string& message) {
  std::fprintf(stderr, "tally_bench_read_latency: %s\n", message.c_str());
  return 1;
}

std::string engineVersion(store::Store& writer) {
  bool postgres = writer.engine() == store::Engine::Postgres;
  store::Statement version(writer.connection(), postgres ? "SHOW server_version" : "SELECT sqlite_version()");
  std::string out =
      std::string(postgres ? "PostgreSQL " : "SQLite ") + (version.step() ? version.getText(0) : "?");
  version.run();
  if (postgres) {
    for (const char* setting : {"shared_buffers", "fsync", "synchronous_commit"}) {
      store::Statement show(writer.connection(), std::string("SHOW ") + setting);  // fixed names only
      out += std::string(", ") + setting + " " + (show.step() ? show.getText(0) : "?");
      show.run();
    }
  }
  return out;
}

int run(const Options& options) {
  signal(SIGPIPE, SIG_IGN);
  const bool temporary = options.db.empty();
  const std::string path =
      temporary ? (fs::temp_directory_path() / ("tally_bench_" + std::to_string(getpid()) + ".db")).string()
                : options.db;
  if (temporary) removeDatabase(path);
  struct Cleanup {
    bool active;
    std::string path;
    ~Cleanup() {
      if (active) removeDatabase(path);
    }
  } cleanup{temporary, path};

  auto writer = store::Store::open(path);
  if (!writer) return fail(writer.error());
  const bool postgres = (*writer)->engine() == store::Engine::Postgres;
  StatementSource source;
  source.postgres = postgres;
  std::string serverStatementsMissing;
  if (postgres) source.server = ServerStatements::connect(path, &serverStatementsMissing);
  const std::string engine = engineVersion(**writer);  // before the server shares the writer
  FillOptions fill{options.samples, options.reuse, options.templatePath, options.json, options.add};
  auto database = prepareDatabase(fill, path, **writer);
  if (!database) return fail(database.error());
  Pools pools = readPools(**writer);
  if (pools.runs.empty()) return fail(database->path + " holds no runs");

  installStatementTrace();  // every connection opened from here on: the server's readers
  auto daemon = startDaemon(**writer, path);
  if (!daemon) return fail(daemon.error());
  const int port = (*daemon)->server->port();

  Report report;
  report.postgres = postgres;
  report.engineVersion = engine;
  report.serverStatementsMissing = serverStatementsMissing;
  report.machine = describeMachine();
  report.database = std::move(*database);
  report.server = "http://127.0.0.1:" + std::to_string(port) + "/";
  report.httpThreads = (*daemon)->threads;
  auto cold = timeColdRequests(port, path, pools);
  if (!cold) return fail(cold.error());
  report.cold = std::move(*cold);
  loadIntoPageCache(path);

  auto benches = routeBenches(pools);
  // A route named exactly is that one alone ("GET /api/runs/{id}" is also in
  // its samples' route's name); otherwise every route whose name holds the text.
  const bool exact = std::ranges::any_of(benches, [&](const RouteBench& b) { return b.route == options.route; });
  std::erase_if(benches, [&](const RouteBench& b) {
    return exact ? b.route != options.route : b.route.find(options.route) == std::string::npos;
  });
  if (benches.empty()) return fail("--route: no route's name holds " + options.route);
  report.figures = timeRoutes(port, options, benches, report.httpThreads, source);
  bool failed = false;
  for (const auto& bench : benches) {
    if (postgres && !source.server) break;  // nothing to show
    auto plan = postgres ? serverStatementsOf(port, path, *source.server, bench) : planRoute(port, path, bench);
    if (!plan) {
      fail("plans of " + bench.route + ": " + plan.error());
      failed = true;
      continue;
    }
    report.plans.push_back(std::move(*plan));
  }
  (*daemon)->server->stop();
  report.machine.loadAfter = loadAverage();

  if (options.json) {
    printJson(report);
  } else {
    printText(report);
  }
  for (const auto& f : report.figures) failed = failed || f.summary.errors > 0 || f.summary.count == 0;
  return failed ? 1 : 0;
}

}  // namespace
}  // namespace tally::bench

int main(int argc, char** argv) {
  tally::bench::Options options;
  CLI::App app{"tally_bench_read_latency: read latency of the REST API over a database of N samples"};
  app.add_option("--samples", options.samples, "Samples to store (10 per run, 200 per capture)")
      ->capture_default_str()
      ->check(CLI::Range(int64_t{1}, int64_t{100'000'000}));
  app.add_option("--requests", options.requests, "Requests per route and client count (pages for the walk)")
      ->capture_default_str()
      ->check(CLI::Range(size_t{1}, size_t{10'000'000}));
  app.add_option("--clients", options.clients, "Concurrent clients for the second round")
      ->capture_default_str()
      ->check(CLI::Range(2, 64));
  app.add_option("--seconds", options.seconds, "Time limit per route and client count")
      ->capture_default_str()
      ->check(CLI::Range(1, 3600));
  auto* db = app.add_option("--db", options.db,
                            "Keep the database in this file, or use this postgresql:// database (default: a "
                            "temporary file)");
  auto* reuse =
      app.add_flag("--reuse", options.reuse, "Use the samples already in --db instead of refusing it")->needs(db);
  app.add_option("--add", options.add,
                 "With --reuse: ingest this many samples more first, timed as a fill is (the ingest's rate at the "
                 "database's size)")
      ->needs(reuse)
      ->check(CLI::Range(int64_t{1}, int64_t{100'000'000}));
  app.add_flag("--json", options.json, "Print the figures as JSON");
  app.add_option("--route", options.route,
                 "Time only the route of this name, or those whose name holds it (default: all)");
  app.add_option("--template", options.templatePath,
                 "Capture result whose shapes the samples take (JSON or .gz)")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return tally::bench::run(options);
  } catch (const std::exception& e) {  // database errors of the benchmark's own queries
    std::fprintf(stderr, "tally_bench_read_latency: %s\n", e.what());
    return 1;
  }
}
