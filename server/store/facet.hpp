// What the facets of one Store (JobQueue, Hosts, Runs, Alerts) share: the
// Store's one connection, and the mutex that lets one call at a time use it,
// whichever facet makes the call.
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "store/db.hpp"
#include "store/statistics_keeper.hpp"

namespace tally::store {

class Store;

struct Shared {
  Shared(Connection* connection, std::string where) : db(connection), location(std::move(where)) {}
  Connection* db;
  std::string location;  // as given to Store::open: the job queue's wake-ups are keyed by it
  std::mutex mutex;  // one call at a time on this connection
  // PostgreSQL: samples this Store ingested since it last asked for the
  // growing tables' statistics, and who keeps them (made by the first ask;
  // Runs::ingestCapture).
  int64_t samplesSinceAnalyze = 0;
  std::unique_ptr<StatisticsKeeper> statistics;
};

// A facet is a view of its Store's connection: the Store makes it, and it
// lives as long as the Store, so it is handed out by reference, never copied.
class Facet {
 public:
  Facet(const Facet&) = delete;
  Facet& operator=(const Facet&) = delete;

 protected:
  explicit Facet(Shared& shared)
      : db_(shared.db), mutex_(shared.mutex), location_(shared.location), shared_(shared) {}
  ~Facet() = default;
  Connection* db_;
  std::mutex& mutex_;
  const std::string& location_;
  Shared& shared_;
};

}  // namespace tally::store
