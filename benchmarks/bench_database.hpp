// The benchmark's database: filled through the store (or reused), described
// (size, rows, largest tables), and the ids and filter values requests use.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/result.hpp"
#include "report.hpp"
#include "store/store.hpp"

namespace tally::bench {

struct FillOptions {
  int64_t samples = 0;
  bool reuse = false;  // a database that holds samples is used as found, not refused
  std::string templatePath;
  bool quiet = false;  // no progress lines
  // With reuse: samples to ingest into the database as found, before it is
  // described (the ingest's rate at the database's size; the fill's figures
  // then describe these).
  int64_t add = 0;
};

// Fills the writer's database when it holds no samples (or adds `add` to it), then checkpoints
// the WAL (SQLite) and describes it. path: a SQLite file or a PostgreSQL URL.
Result<DatabaseReport> prepareDatabase(const FillOptions& options, const std::string& path,
                                       store::Store& writer);

// What the routes are asked about: ids and filter values that exist.
struct Pools {
  std::vector<int64_t> runs, samples, devices, captures;
  std::vector<std::string> renderers, deviceNames, scenes;
  std::vector<std::pair<int64_t, int64_t>> resolutions;
};
Pools readPools(store::Store& writer);

void removeDatabase(const std::string& path);  // with its -wal and -shm; nothing for a PostgreSQL URL

// Drops the file's pages from the OS page cache (this file's only), so that
// the next reads come from the disk. Nothing for a PostgreSQL URL: the
// server's shared buffers and files are out of this process's reach.
void evictFromPageCache(const std::string& path);
// Reads the file once, so that later reads find it in the page cache, as on
// a daemon that has served for a while. Nothing for a PostgreSQL URL.
void loadIntoPageCache(const std::string& path);

}  // namespace tally::bench
