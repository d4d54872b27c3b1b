#include "bench_database.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "renderers/renderer.hpp"
#include "store/sqlite.hpp"
#include "synthetic_captures.hpp"

namespace tally::bench {
namespace {

namespace fs = std::filesystem;

// The benchmark's own queries: fixed SQL, one value per row.
template <class T>
std::vector<T> column(store::Connection& db, const char* sql, T (*read)(const store::Statement&)) {
  store::Statement query(db, sql);
  std::vector<T> out;
  while (query.step()) out.push_back(read(query));
  return out;
}

int64_t intAt0(const store::Statement& s) { return s.getInt(0); }
std::string textAt0(const store::Statement& s) { return s.getText(0); }
std::pair<int64_t, int64_t> intsAt01(const store::Statement& s) { return {s.getInt(0), s.getInt(1)}; }
std::pair<std::string, uint64_t> nameAndBytes(const store::Statement& s) {
  return {s.getText(0), static_cast<uint64_t>(s.getInt(1))};
}

int64_t sampleCount(store::Connection& db) { return column(db, "SELECT COUNT(*) FROM samples", intAt0).at(0); }

std::vector<std::pair<std::string, int64_t>> rowCounts(store::Connection& db) {
  std::vector<std::pair<std::string, int64_t>> out;
  for (const char* table :
       {"jobs", "devices", "runs", "run_resources", "samples", "passes", "counters", "screenshots"}) {
    std::string sql = std::string("SELECT COUNT(*) FROM ") + table;  // fixed names only
    out.emplace_back(table, column(db, sql.c_str(), intAt0).at(0));
  }
  return out;
}

// The largest tables and indexes by the pages they take; empty when this
// SQLite lacks the dbstat table.
std::vector<std::pair<std::string, uint64_t>> largestObjects(store::Connection& db) {
  try {
    if (db.engine() == store::Engine::Postgres) {
      return column(db,
                    "SELECT c.relname, pg_relation_size(c.oid) FROM pg_class c JOIN pg_namespace n ON "
                    "n.oid = c.relnamespace WHERE n.nspname = current_schema() AND c.relkind IN ('r', 'i') "
                    "ORDER BY 2 DESC LIMIT 6",
                    nameAndBytes);
    }
    return column(db, "SELECT name, SUM(pgsize) FROM dbstat GROUP BY name ORDER BY 2 DESC LIMIT 6",
                  nameAndBytes);
  } catch (const store::DbError&) {
    return {};
  }
}

uint64_t databaseBytes(store::Connection& db, const std::string& path) {
  if (db.engine() == store::Engine::Postgres) {
    return static_cast<uint64_t>(column(db, "SELECT pg_database_size(current_database())", intAt0).at(0));
  }
  db.exec("PRAGMA wal_checkpoint(TRUNCATE)");
  uint64_t bytes = 0;
  for (const char* suffix : {"", "-wal"}) {
    std::error_code ec;
    auto size = fs::file_size(path + suffix, ec);
    if (!ec) bytes += size;
  }
  return bytes;
}

}  // namespace

Result<DatabaseReport> prepareDatabase(const FillOptions& options, const std::string& path,
                                       store::Store& writer) {
  DatabaseReport out;
  out.path = store::isPostgresUrl(path) ? store::redactUrl(path) : path;
  bool empty = sampleCount(writer.connection()) == 0;
  if (!empty && !options.reuse) {
    return makeError(out.path + " already holds samples; pass --reuse, or remove it" +
                     (store::isPostgresUrl(path) ? " (drop and create the database)" : ""));
  }
  if (empty || options.add > 0) {
    const int64_t samples = empty ? options.samples : options.add;
    auto renderers = renderers::rendererNames();
    auto source = loadTemplate(options.templatePath, renderers);
    if (!source) return makeError("capture template: " + source.error());
    int64_t nextReport = 0;
    auto progress = [&](int64_t stored) {
      if (options.quiet || stored < nextReport) return;
      std::fprintf(stderr, "filling: %lld of %lld samples\n", static_cast<long long>(stored),
                   static_cast<long long>(samples));
      nextReport = stored + std::max<int64_t>(1, samples / 10);
    };
    auto filled = fillDatabase(writer, *source, renderers, samples, progress);
    if (!filled) return makeError(filled.error());
    out.filled = true;
    out.added = !empty;
    out.fill = *filled;
  }
  out.bytes = databaseBytes(writer.connection(), path);
  out.rows = rowCounts(writer.connection());
  out.largest = largestObjects(writer.connection());
  return out;
}

Pools readPools(store::Store& writer) {
  store::Connection& db = writer.connection();
  Pools p;
  p.runs = column(db, "SELECT id FROM runs", intAt0);
  p.samples = column(db, "SELECT id FROM samples", intAt0);
  p.devices = column(db, "SELECT id FROM devices", intAt0);
  p.captures = column(db, "SELECT DISTINCT job_id FROM runs", intAt0);
  p.renderers = column(db, "SELECT DISTINCT renderer FROM runs", textAt0);
  p.deviceNames = column(db, "SELECT DISTINCT name FROM devices", textAt0);
  p.scenes = column(db, "SELECT DISTINCT name FROM scenes", textAt0);
  p.resolutions = column(db, "SELECT DISTINCT width, height FROM runs", intsAt01);
  return p;
}

void removeDatabase(const std::string& path) {
  if (store::isPostgresUrl(path)) return;  // a server's database is the user's to drop
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path + suffix);
}

void evictFromPageCache(const std::string& path) {
  if (store::isPostgresUrl(path)) return;  // the server's cache is its own
  int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  ::close(fd);
}

void loadIntoPageCache(const std::string& path) {
  if (store::isPostgresUrl(path)) return;
  std::ifstream in(path, std::ios::binary);
  std::vector<char> buffer(1 << 20);
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
  }
}

}  // namespace tally::bench
