// StoreHealth: what /api/health and /metrics say about the store, and what
// write routes check before they write.
//
// At start and every checkInterval, SQLite's PRAGMA quick_check (PostgreSQL:
// a round trip) runs on a connection of its own, on this object's thread, so
// that a check of a large file (seconds per GB) holds no request. Faults that
// requests and the worker meet are reported here too: a damaged file (until a
// check finds it whole again), a full disk or an I/O error (until a write
// probe goes through, tried every retryInterval), an unreachable server
// (until a round trip answers). A busy store is not a fault of its health:
// those requests answer 503 and the next one may pass.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "service/loop_thread.hpp"
#include "store/store.hpp"

namespace tally::service {

struct StoreHealthOptions {
  std::string location;  // the SQLite file or postgresql:// URL
  // Between scheduled checks; 0: at start only. PostgreSQL's round trip
  // runs at least every retryInterval x 15 (30 s by default).
  std::chrono::seconds checkInterval{3600};
  std::chrono::milliseconds retryInterval{2000};  // probes while a fault lasts
  std::function<void(std::string_view)> log;      // fault lines; may be empty
};

class StoreHealth {
 public:
  explicit StoreHealth(StoreHealthOptions options);
  ~StoreHealth();  // stop()
  StoreHealth(const StoreHealth&) = delete;
  StoreHealth& operator=(const StoreHealth&) = delete;

  // The check at start, on the caller's thread (before serving).
  void checkNow();
  void start();  // the scheduled checks and probes
  void stop();

  // A store call failed with `fault` (kNone and kBusy change nothing);
  // detail is logged, not shown to clients.
  void noteFault(store::Fault fault, const std::string& detail);
  // A write went through: a write fault is over.
  void noteWriteOk();

  struct State {
    store::Fault fault = store::Fault::kNone;
    std::string reason;       // for clients: what is wrong, with the check's words for damage
    std::string since;        // UTC ISO-8601 of the fault's start; "" when none
    std::string checkedAt;    // the last check's end; "" before the first
    double checkSeconds = 0;  // how long it took
    std::string checkResult;  // "ok", or the check's first lines
  };
  State state() const;
  bool ok() const { return state().fault == store::Fault::kNone; }
  // {"status": "ok" | the fault's name, "engine", "reason", "since",
  //  "checked_at", "check_seconds", "check"}.
  nlohmann::json toJson() const;

 private:
  void runCheck();
  void probe();
  // keepReason: an open fault of the same kind keeps the reason it has.
  void setFault(store::Fault fault, std::string reason, bool keepReason = false);

  StoreHealthOptions options_;
  bool postgres_ = false;
  mutable std::mutex mutex_;
  State state_;
  bool recheck_ = false;                                // a request met damage: check again soon
  store::Fault lastDetailFault_ = store::Fault::kNone;  // the fault whose detail was logged last, and when
  std::chrono::steady_clock::time_point lastDetail_;
  std::unique_ptr<store::Store> checker_;  // read-only, for the checks
  std::unique_ptr<store::Store> prober_;   // writable, for the write probe
  LoopThread loop_;
};

}  // namespace tally::service
