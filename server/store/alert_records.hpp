// The store's baseline and alert records (0009; docs/statistics.md,
// "Alerts"): what the Alerts facet (alerts.hpp) reads and writes.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/run_records.hpp"

namespace tally::store {

// ---- baselines and alerts (0009) -------------------------------------------------

// A configuration's baseline: the run new runs of the configuration are
// tested against (docs/statistics.md, "Alerts"). The configuration is the
// run's renderer and canonical options, scene (with its parameters),
// resolution, device and counting mode; not its lights, nor its labels.
struct Baseline {
  int64_t id = 0;
  std::optional<std::string> name;
  int64_t runId = 0;
  std::string renderer, variant;
  nlohmann::json options = nlohmann::json::object();
  std::string scene;
  nlohmann::json sceneParams = nlohmann::json::object();
  int width = 0, height = 0;
  int64_t deviceId = 0;
  std::string deviceName, counting;
  double threshold = 0.05;  // |ratio - 1| beyond which a significant time change alerts
  std::string status;       // active | replaced | removed
  std::string createdAt;
  std::optional<std::string> endedAt;
  std::optional<int64_t> replacedBy;
  nlohmann::json labels = nlohmann::json::object();  // the baseline run's labels
  int64_t openAlerts = 0;
};

struct NewBaseline {
  int64_t runId = 0;
  double threshold = 0.05;
  std::optional<std::string> name;
};

struct SetBaseline {
  Baseline baseline;
  std::optional<int64_t> replaced;  // the active baseline of the configuration it replaced
};

enum class AlertStatus { Open, Acknowledged, Invalid, Fixed };
const char* toString(AlertStatus status);  // "open", "acknowledged", ...
std::optional<AlertStatus> parseAlertStatus(std::string_view name);

// One change of a run against its baseline run, as the evaluator found it.
struct NewAlert {
  std::string kind;     // time | counts
  std::string metric;   // "frame", "pass NAME" or "counts"
  std::string verdict;  // slower | faster | changed
  std::optional<double> ratio, ratioLower, ratioUpper, pValue, cliffsDelta;
  std::optional<double> valueA, valueB;  // medians in ms (time), total bytes per frame (counts)
  nlohmann::json details = nlohmann::json::object();
};

struct Alert {
  int64_t id = 0;
  int64_t baselineId = 0, runId = 0, baselineRunId = 0;
  NewAlert figures;
  std::string status;  // open | acknowledged | invalid | fixed
  std::string createdAt;
  std::optional<std::string> updatedAt;
  // The webhook's outbox: none | pending | delivered | failed.
  std::string delivery;
  int deliveryAttempts = 0;
  std::optional<int64_t> nextAttemptMs;
  std::optional<std::string> deliveryError, deliveredAt;
};

struct AlertFilter {
  std::optional<AlertStatus> status;
  std::optional<int64_t> baselineId;
  std::optional<int64_t> runId;
};

struct AlertPage {
  std::vector<Alert> alerts;  // newest first (descending id)
  std::string nextCursor;     // empty when this was the last page
};

// Tests a run against its baseline's run: the alerts to raise (none: no
// change). Called by Alerts::evaluatePending (on PostgreSQL inside its write
// transaction), so it must read through another connection, never this Store.
using RunEvaluator = std::function<Result<std::vector<NewAlert>>(const RunRow& run, const Baseline& baseline)>;

struct Evaluated {
  int64_t runs = 0;               // runs marked evaluated
  int64_t tested = 0;             // of those, runs with a baseline to test against
  std::vector<int64_t> alertIds;  // the alerts raised
};

}  // namespace tally::store
