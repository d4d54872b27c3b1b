// Baselines, the alerts raised against them and the webhook's outbox, a
// facet of the Store (store.alerts(); docs/statistics.md, "Alerts").
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "store/alert_records.hpp"
#include "store/facet.hpp"

namespace tally::store {

class Alerts : public Facet {
 public:
  // Baselines (0009). setBaseline: the run's configuration gets the run as
  // its baseline, replacing (and recording) an active one; empty: no such run.
  Result<std::optional<SetBaseline>> setBaseline(const NewBaseline& baseline);
  // Active baselines (with every status when `all`), newest first.
  Result<std::vector<Baseline>> listBaselines(bool all = false);
  Result<std::optional<Baseline>> getBaseline(int64_t baselineId);
  // active -> removed (its alerts stay); empty: no such baseline. A baseline
  // already ended is returned unchanged.
  Result<std::optional<Baseline>> removeBaseline(int64_t baselineId);
  // The runs of a baseline's configuration, oldest first, at most `limit`
  // (the newest ones when there are more).
  Result<std::vector<RunRow>> configurationRuns(int64_t baselineId, int limit);

  // Takes up to `limit` runs not yet evaluated, tests each run that
  // has an active baseline older than it with `evaluate`, inserts the alerts
  // (delivery pending when `deliver`, else none) and marks the runs
  // evaluated. On PostgreSQL the runs are claimed FOR UPDATE SKIP LOCKED and
  // all of it is one transaction: two daemons never test one run. On SQLite
  // the runs are tested before the write transaction (the file's one write
  // lock is not held while they are), which then marks each run still
  // unevaluated and stores its alerts: a run raises its alerts once. An
  // evaluator error stores nothing of the pass.
  Result<Evaluated> evaluatePending(const RunEvaluator& evaluate, int limit, bool deliver);
  Result<AlertPage> list(const AlertFilter& filter, const Page& page);
  Result<std::optional<Alert>> get(int64_t alertId);
  // Alerts by status, each status present; for `baselineId` only when given.
  Result<std::map<std::string, int64_t>> counts(std::optional<int64_t> baselineId = {});
  // Empty: no such alert.
  Result<std::optional<Alert>> setStatus(int64_t alertId, AlertStatus status);
  // Every alert of a baseline's configuration's runs (any baseline of it), oldest first, at most limit.
  Result<std::vector<Alert>> configurationAlerts(int64_t baselineId, int limit);

  // The webhook's outbox. Claims up to `limit` pending alerts whose next
  // attempt is due: attempts + 1, and the next attempt pushed claimMs ahead,
  // so no other daemon takes them while this one posts (SKIP LOCKED on
  // PostgreSQL). Then finishDelivery records the outcome: delivered, or the
  // error with a retry after retryInMs, or failed for good (no retry).
  Result<std::vector<Alert>> claimDeliveries(int limit, int64_t claimMs);
  Result<bool> finishDelivery(int64_t alertId, bool delivered, const std::string& error,
                              std::optional<int64_t> retryInMs);

 private:
  friend class Store;
  explicit Alerts(Shared& shared) : Facet(shared) {}
};

}  // namespace tally::store
