// PostgreSQL plans statements from the tables' statistics, which autovacuum
// refreshes at most once a minute; ingests that grow a young database many
// times over within that minute leave it planned as if nearly empty
// (Runs::ingestCapture decides when to analyse). The keeper runs those
// ANALYZEs on a connection and a thread of its own, so that no ingest waits
// for one: request() returns at once, and the requests made while an ANALYZE
// runs are served by one more after it.
//
//   StatisticsKeeper keeper(url);
//   keeper.request();     // after a commit that grew the tables
//   keeper.waitIdle();    // tools and tests: until what was asked is done
//
// ANALYZE takes a lock that inserts do not wait for. A failure (the server
// gone, a lock timeout) costs plans, not data: it is counted, its message
// kept, and the next request tries again on a new connection.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "store/db.hpp"

namespace tally::store {

class StatisticsKeeper {
 public:
  explicit StatisticsKeeper(std::string location) : location_(std::move(location)) {}
  ~StatisticsKeeper();  // lets a running ANALYZE finish, then stops
  StatisticsKeeper(const StatisticsKeeper&) = delete;
  StatisticsKeeper& operator=(const StatisticsKeeper&) = delete;

  // Asks for one ANALYZE of the growing tables after everything committed so far.
  void request();
  // Blocks until no ANALYZE is running or asked for.
  void waitIdle();

  struct State {
    int64_t analyses = 0;          // finished
    int64_t failures = 0;          // failed (each retried at the next request)
    std::string lastFailure;       // the last failure's message
    int64_t samplesAtAnalyze = 0;  // the samples the database held at the last ANALYZE (reltuples)
  };
  State state() const;

 private:
  void loop();
  void analyse();  // one ANALYZE, on the keeper's connection (opened when missing)

  const std::string location_;
  std::unique_ptr<Connection> db_;  // the thread's alone
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool asked_ = false, running_ = false, stopping_ = false;
  State state_;
  std::thread thread_;  // started by the first request
};

}  // namespace tally::store
