// Regression alerts (docs/statistics.md, "Alerts"): each new run of a
// configuration that has a baseline is tested against the baseline's run,
// by a thread of the daemons that serve the API (role api or all), never by
// a worker. Runs are claimed in the store (FOR UPDATE SKIP LOCKED on
// PostgreSQL), so several API daemons sharing one database test each run
// once, and the alerts and the run's "evaluated" mark are written in one
// transaction.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.hpp"
#include "service/loop_thread.hpp"
#include "store/store.hpp"

namespace tally::service {

// Runs claimed per transaction; a transaction evaluates them one after another.
inline constexpr int kEvaluationBatch = 8;

// The alerts of `run` against `baseline`'s run, read through `reader` (not the
// store that holds the evaluation's transaction):
//   - time: the frame time and each pass's GPU time both runs have, over
//     per-frame times (reports/run_significance.hpp), with the baseline's
//     threshold as the practical threshold: an alert when the verdict is
//     slower or faster;
//   - counts: one alert when the total bytes or any counter line differs
//     (exactly), naming every change.
Result<std::vector<store::NewAlert>> evaluateRun(store::Store& reader, const store::RunRow& run,
                                                 const store::Baseline& baseline);

// One evaluation pass over up to `batch` runs not yet evaluated: the runs
// evaluated, tested and the alerts raised. `writer` claims and writes;
// `reader` is another connection to the same database.
Result<store::Evaluated> evaluatePending(store::Store& writer, store::Store& reader, bool deliver,
                                         int batch = kEvaluationBatch);

// The evaluator thread: opens its own writer and reader on `location`,
// evaluates until nothing is pending, then waits `idle` (or a wake()).
class AlertEvaluator {
 public:
  struct Options {
    std::string location;                  // the store (a SQLite file or postgresql:// URL)
    bool deliver = false;                  // a webhook is set: new alerts are pending delivery
    std::chrono::milliseconds idle{1000};  // between passes that found nothing
    std::function<void(std::string_view)> log;
    std::function<void(const store::Evaluated&)>
        onEvaluated;  // after a pass that evaluated runs; may be empty
  };
  explicit AlertEvaluator(Options options);
  ~AlertEvaluator();
  AlertEvaluator(const AlertEvaluator&) = delete;
  AlertEvaluator& operator=(const AlertEvaluator&) = delete;
  void start();
  void stop();
  void wake();

 private:
  void loop();
  Options options_;
  LoopThread thread_;
};

}  // namespace tally::service
