// The read-only stores of the service's request threads: one per thread,
// opened at its first read and closed with the service (ServiceContext owns
// them). A store connection is used by one thread at a time; the HTTP
// server's threads are a fixed pool, so there are as many as it has threads.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "store/store.hpp"

namespace tally::service {

class ReadStores {
 public:
  explicit ReadStores(std::string dbPath) : dbPath_(std::move(dbPath)) {}
  ReadStores(const ReadStores&) = delete;
  ReadStores& operator=(const ReadStores&) = delete;

  // The calling thread's store, opened now when it has none; throws
  // detail::StoreUnavailable when it cannot be opened.
  store::Store& forThisThread();

 private:
  const std::string dbPath_;
  std::mutex mutex_;  // guards the map, not the stores (each is its thread's)
  std::map<std::thread::id, std::unique_ptr<store::Store>> stores_;
};

}  // namespace tally::service
