// Baselines, the alerts raised against them and the webhook's outbox (0009;
// docs/statistics.md, "Alerts"). The evaluation of new runs and the outbox
// are claimed FOR UPDATE SKIP LOCKED on PostgreSQL, so several API daemons
// sharing one database never test one run twice nor post one alert at once.
#include <algorithm>
#include <cmath>

#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;
using nlohmann::json;

namespace {

const char* const kBaselineSelect =
    "SELECT b.id, b.name, b.run_id, b.renderer, COALESCE(r.variant, b.renderer), b.options, sc.name, "
    "sc.params, "
    "b.width, b.height, b.device_id, d.name, b.counting, b.threshold, b.status, b.created_at, b.ended_at, "
    "b.replaced_by, (SELECT j.labels FROM jobs j WHERE j.id = r.job_id), "
    "(SELECT COUNT(*) FROM alerts a WHERE a.baseline_id = b.id AND a.status = 'open') "
    "FROM baselines b JOIN runs r ON r.id = b.run_id JOIN scenes sc ON sc.id = b.scene_id "
    "JOIN devices d ON d.id = b.device_id";

Baseline readBaseline(const Statement& statement) {
  RowReader row(statement);
  Baseline b;
  b.id = row.getInt();
  b.name = row.getOptText();
  b.runId = row.getInt();
  b.renderer = row.getText();
  b.variant = row.getText();
  b.options = row.getJson();
  b.scene = row.getText();
  b.sceneParams = row.getJson();
  b.width = static_cast<int>(row.getInt());
  b.height = static_cast<int>(row.getInt());
  b.deviceId = row.getInt();
  b.deviceName = row.getText();
  b.counting = row.getText();
  b.threshold = row.getDouble();
  b.status = row.getText();
  b.createdAt = row.getText();
  b.endedAt = row.getOptText();
  b.replacedBy = row.getOptInt();
  json labels = row.getJson();
  b.labels = labels.is_null() ? json::object() : std::move(labels);
  b.openAlerts = row.getInt();
  row.end();
  return b;
}

std::optional<Baseline> findBaseline(Connection* db, int64_t id) {
  Statement query(db, std::string(kBaselineSelect) + " WHERE b.id = ?1");
  query.bind(1, id);
  if (!query.step()) return std::nullopt;
  return readBaseline(query);
}

const char* const kAlertColumns =
    "a.id, a.baseline_id, a.run_id, a.baseline_run_id, a.kind, a.metric, a.verdict, a.ratio, a.ratio_lower, "
    "a.ratio_upper, a.p_value, a.cliffs_delta, a.value_a, a.value_b, a.details, a.status, a.created_at, "
    "a.updated_at, a.delivery, a.delivery_attempts, a.next_attempt_ms, a.delivery_error, a.delivered_at";

Alert readAlert(const Statement& statement) {
  RowReader row(statement);
  Alert a;
  a.id = row.getInt();
  a.baselineId = row.getInt();
  a.runId = row.getInt();
  a.baselineRunId = row.getInt();
  a.figures.kind = row.getText();
  a.figures.metric = row.getText();
  a.figures.verdict = row.getText();
  a.figures.ratio = row.getOptDouble();
  a.figures.ratioLower = row.getOptDouble();
  a.figures.ratioUpper = row.getOptDouble();
  a.figures.pValue = row.getOptDouble();
  a.figures.cliffsDelta = row.getOptDouble();
  a.figures.valueA = row.getOptDouble();
  a.figures.valueB = row.getOptDouble();
  a.figures.details = row.getJson();
  a.status = row.getText();
  a.createdAt = row.getText();
  a.updatedAt = row.getOptText();
  a.delivery = row.getText();
  a.deliveryAttempts = static_cast<int>(row.getInt());
  a.nextAttemptMs = row.getOptInt();
  a.deliveryError = row.getOptText();
  a.deliveredAt = row.getOptText();
  row.end();
  return a;
}

std::optional<Alert> findAlert(Connection* db, int64_t id) {
  Statement query(db, std::string("SELECT ") + kAlertColumns + " FROM alerts a WHERE a.id = ?1");
  query.bind(1, id);
  if (!query.step()) return std::nullopt;
  return readAlert(query);
}

// A configuration's columns, compared between a runs row r and a baselines row b.
const char* const kSameConfiguration =
    "r.renderer = b.renderer AND r.options = b.options AND r.scene_id = b.scene_id AND r.width = b.width AND "
    "r.height = b.height AND r.device_id = b.device_id AND r.counting = b.counting";

// NaN and infinities are not numbers JSON or a CHECK-free REAL column should
// keep: an unbounded interval end is stored as NULL.
std::optional<double> finite(std::optional<double> v) {
  if (v && !std::isfinite(*v)) return std::nullopt;
  return v;
}

}  // namespace

const char* toString(AlertStatus status) {
  switch (status) {
    case AlertStatus::Open: return "open";
    case AlertStatus::Acknowledged: return "acknowledged";
    case AlertStatus::Invalid: return "invalid";
    case AlertStatus::Fixed: return "fixed";
  }
  return "unknown";
}

std::optional<AlertStatus> parseAlertStatus(std::string_view name) {
  for (AlertStatus s :
       {AlertStatus::Open, AlertStatus::Acknowledged, AlertStatus::Invalid, AlertStatus::Fixed}) {
    if (name == toString(s)) return s;
  }
  return std::nullopt;
}

// ---- baselines -----------------------------------------------------------------------

Result<std::optional<SetBaseline>> Alerts::setBaseline(const NewBaseline& nb) {
  if (!(nb.threshold >= 0) || !std::isfinite(nb.threshold))
    return makeError("threshold: must be a number >= 0");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<SetBaseline>>("setBaseline", [&]() -> Result<std::optional<SetBaseline>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement run(db_, "SELECT id FROM runs WHERE id = ?1");
    run.bind(1, nb.runId);
    if (!run.step()) return std::optional<SetBaseline>();
    run.run();
    SetBaseline out;
    // The configuration's active baseline, locked so that two daemons setting
    // one configuration's baseline at once take turns.
    Statement active(db_, std::string("SELECT b.id FROM baselines b JOIN runs r ON ") + kSameConfiguration +
                              " WHERE r.id = ?1 AND b.status = 'active'" +
                              (db_->engine() == Engine::Postgres ? " FOR UPDATE OF b" : ""));
    active.bind(1, nb.runId);
    if (active.step()) out.replaced = active.getInt(0);
    active.run();
    if (out.replaced) {
      Statement end(db_, std::string("UPDATE baselines SET status = 'replaced', ended_at = ") + nowSql(*db_) +
                             " WHERE id = ?1");
      end.bind(1, *out.replaced).run();
    }
    Statement insert(
        db_,
        "INSERT INTO baselines (name, run_id, renderer, options, scene_id, width, height, device_id, "
        "counting, threshold) SELECT ?1, r.id, r.renderer, r.options, r.scene_id, r.width, r.height, "
        "r.device_id, r.counting, ?2 FROM runs r WHERE r.id = ?3 RETURNING id");
    insert.bind(1, nb.name).bind(2, nb.threshold).bind(3, nb.runId);
    if (!insert.step()) return makeError("the baseline was not inserted");
    int64_t id = insert.getInt(0);
    insert.run();
    if (out.replaced) {
      Statement link(db_, "UPDATE baselines SET replaced_by = ?1 WHERE id = ?2");
      link.bind(1, id).bind(2, *out.replaced).run();
    }
    out.baseline = findBaseline(db_, id).value();
    tx.commit();
    return std::optional<SetBaseline>(std::move(out));
  });
}

Result<std::vector<Baseline>> Alerts::listBaselines(bool all) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<Baseline>>("listBaselines", [&]() -> Result<std::vector<Baseline>> {
    Statement query(db_, std::string(kBaselineSelect) + (all ? "" : " WHERE b.status = 'active'") +
                             " ORDER BY b.id DESC");
    std::vector<Baseline> out;
    while (query.step()) out.push_back(readBaseline(query));
    return out;
  });
}

Result<std::optional<Baseline>> Alerts::getBaseline(int64_t id) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Baseline>>("getBaseline", [&] { return Result(findBaseline(db_, id)); });
}

Result<std::optional<Baseline>> Alerts::removeBaseline(int64_t id) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<Baseline>>("removeBaseline", [&]() -> Result<std::optional<Baseline>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement end(db_, std::string("UPDATE baselines SET status = 'removed', ended_at = ") + nowSql(*db_) +
                           " WHERE id = ?1 AND status = 'active'");
    end.bind(1, id).run();
    auto out = findBaseline(db_, id);
    tx.commit();
    return out;
  });
}

Result<std::vector<RunRow>> Alerts::configurationRuns(int64_t baselineId, int limit) {
  if (limit < 1) return makeError("limit: must be at least 1");
  std::lock_guard lock(mutex_);
  return guarded<std::vector<RunRow>>("configurationRuns", [&]() -> Result<std::vector<RunRow>> {
    Transaction tx(db_, Transaction::Kind::Read);
    Statement query(db_, detail::runSelect(*db_, std::string("WHERE r.id IN (SELECT r.id FROM runs r JOIN baselines b ON ") +
                                           kSameConfiguration + " WHERE b.id = ?1 ORDER BY r.id DESC LIMIT ?2)") +
                             " ORDER BY r.id");
    query.bind(1, baselineId).bind(2, limit);
    std::vector<RunRow> out;
    while (query.step()) out.push_back(detail::readRunRow(query));
    return out;
  });
}

// ---- evaluation ---------------------------------------------------------------------------

namespace {

// A run to evaluate: its row and, when its configuration has an active
// baseline older than it, that baseline.
struct Candidate {
  int64_t runId = 0;
  std::optional<RunRow> run;
  std::optional<Baseline> baseline;
};

// The runs picked by `pick` (their ids in its first column) with their baselines.
std::vector<Candidate> candidates(Connection* db, Statement& pick) {
  std::vector<Candidate> out;
  while (pick.step()) out.push_back({pick.getInt(0), std::nullopt, std::nullopt});
  Statement findBase(db, std::string("SELECT b.id FROM baselines b JOIN runs r ON ") + kSameConfiguration +
                             " WHERE r.id = ?1 AND b.status = 'active' AND b.run_id < r.id");
  Statement runRow(db, detail::runSelect(*db, "WHERE r.id = ?1"));
  for (auto& c : out) {
    findBase.reset();
    findBase.bind(1, c.runId);
    std::optional<int64_t> baselineId;
    if (findBase.step()) baselineId = findBase.getInt(0);
    findBase.run();
    if (!baselineId) continue;
    runRow.reset();
    runRow.bind(1, c.runId);
    if (runRow.step()) c.run = detail::readRunRow(runRow);
    runRow.run();
    c.baseline = findBaseline(db, *baselineId);
  }
  return out;
}

// Inserts a run's alerts; their ids are appended to `ids`.
void insertAlerts(Connection* db, const Candidate& c, const std::vector<NewAlert>& alerts, bool deliver,
                  std::vector<int64_t>& ids) {
  Statement insert(
      db,
      "INSERT INTO alerts (baseline_id, run_id, baseline_run_id, kind, metric, verdict, ratio, "
      "ratio_lower, ratio_upper, p_value, cliffs_delta, value_a, value_b, details, delivery, "
      "next_attempt_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16) "
      "RETURNING id");
  for (const auto& a : alerts) {
    insert.reset();
    insert.bind(1, c.baseline->id)
        .bind(2, c.runId)
        .bind(3, c.baseline->runId)
        .bind(4, a.kind)
        .bind(5, a.metric)
        .bind(6, a.verdict)
        .bind(7, finite(a.ratio))
        .bind(8, finite(a.ratioLower))
        .bind(9, finite(a.ratioUpper))
        .bind(10, finite(a.pValue))
        .bind(11, finite(a.cliffsDelta))
        .bind(12, finite(a.valueA))
        .bind(13, finite(a.valueB))
        .bind(14, a.details)
        .bind(15, deliver ? "pending" : "none");
    if (deliver) {
      insert.bind(16, int64_t{0});  // due at once
    } else {
      insert.bind(16, nullptr);
    }
    if (!insert.step()) throw DbError(0, "", "an alert was not inserted");
    ids.push_back(insert.getInt(0));
    insert.run();
  }
}

}  // namespace

Result<Evaluated> Alerts::evaluatePending(const RunEvaluator& evaluate, int limit, bool deliver) {
  if (limit < 1) return makeError("limit: must be at least 1");
  std::unique_lock lock(mutex_);
  if (db_->engine() == Engine::Postgres) {
    // The oldest runs not yet evaluated, locked until this transaction ends;
    // those another daemon is evaluating are skipped, never waited on. Only
    // those rows are locked: workers storing new runs go on meanwhile.
    return guarded<Evaluated>("evaluatePendingRuns", [&]() -> Result<Evaluated> {
      Transaction tx(db_, Transaction::Kind::Write);
      Statement pick(db_, std::string("SELECT id FROM runs WHERE evaluated = 0 ORDER BY id LIMIT ?1") +
                              skipLockedSql(*db_));
      pick.bind(1, limit);
      Evaluated out;
      Statement mark(db_, "UPDATE runs SET evaluated = 1 WHERE id = ?1");
      for (const auto& c : candidates(db_, pick)) {
        if (c.run && c.baseline) {
          auto alerts = evaluate(*c.run, *c.baseline);
          if (!alerts) return makeError("run " + std::to_string(c.runId) + ": " + alerts.error());
          ++out.tested;
          insertAlerts(db_, c, *alerts, deliver, out.alertIds);
        }
        mark.reset();
        mark.bind(1, c.runId).run();
        ++out.runs;
      }
      tx.commit();
      return out;
    });
  }
  // SQLite has one write lock for the whole file: holding it while runs are
  // tested would stall the worker's ingest. So the runs are read and tested
  // first, and the marks and alerts written after, each run's only if it is
  // still unevaluated then: a run tested by two daemons at once gets the
  // alerts of the first to write, once.
  std::vector<Candidate> found;
  {
    auto read = guarded<bool>("evaluatePendingRuns", [&]() -> Result<bool> {
      Transaction tx(db_, Transaction::Kind::Read);
      Statement pick(db_, "SELECT id FROM runs WHERE evaluated = 0 ORDER BY id LIMIT ?1");
      pick.bind(1, limit);
      found = candidates(db_, pick);
      return true;
    });
    if (!read) return makeError(read.error());
  }
  lock.unlock();
  std::vector<std::vector<NewAlert>> results(found.size());
  for (size_t i = 0; i < found.size(); ++i) {
    if (!found[i].run || !found[i].baseline) continue;
    auto alerts = evaluate(*found[i].run, *found[i].baseline);
    if (!alerts) return makeError("run " + std::to_string(found[i].runId) + ": " + alerts.error());
    results[i] = std::move(alerts).value();
  }
  lock.lock();
  detail::WriteLock writer(*db_);
  return guarded<Evaluated>("evaluatePendingRuns", [&]() -> Result<Evaluated> {
    Transaction tx(db_, Transaction::Kind::Write);
    Evaluated out;
    Statement mark(db_, "UPDATE runs SET evaluated = 1 WHERE id = ?1 AND evaluated = 0");
    for (size_t i = 0; i < found.size(); ++i) {
      mark.reset();
      mark.bind(1, found[i].runId).run();
      if (db_->changes() == 0) continue;  // evaluated meanwhile by another daemon, or gone
      ++out.runs;
      if (!found[i].run || !found[i].baseline) continue;
      ++out.tested;
      insertAlerts(db_, found[i], results[i], deliver, out.alertIds);
    }
    tx.commit();
    return out;
  });
}

Result<AlertPage> Alerts::list(const AlertFilter& filter, const Page& page) {
  auto after = detail::checkPage(page);
  if (!after) return makeError(after.error());
  std::lock_guard lock(mutex_);
  return guarded<AlertPage>("listAlerts", [&]() -> Result<AlertPage> {
    Statement query(db_, std::string("SELECT ") + kAlertColumns +
                             " FROM alerts a WHERE (CAST(?1 AS TEXT) IS NULL OR a.status = ?1) AND "
                             "(CAST(?2 AS BIGINT) IS NULL OR a.baseline_id = ?2) AND "
                             "(CAST(?3 AS BIGINT) IS NULL OR a.run_id = ?3) AND "
                             "(CAST(?4 AS BIGINT) IS NULL OR a.id < ?4) ORDER BY a.id DESC LIMIT ?5");
    query.bind(1, filter.status ? std::optional<std::string>(toString(*filter.status)) : std::nullopt)
        .bind(2, filter.baselineId)
        .bind(3, filter.runId)
        .bind(4, *after)
        .bind(5, page.limit + 1);  // one more tells whether another page follows
    AlertPage out;
    while (query.step()) {
      if (static_cast<int>(out.alerts.size()) == page.limit) {
        out.nextCursor = encodeCursor(out.alerts.back().id);
        break;
      }
      out.alerts.push_back(readAlert(query));
    }
    return out;
  });
}

Result<std::optional<Alert>> Alerts::get(int64_t id) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Alert>>("getAlert", [&] { return Result(findAlert(db_, id)); });
}

Result<std::map<std::string, int64_t>> Alerts::counts(std::optional<int64_t> baselineId) {
  std::lock_guard lock(mutex_);
  return guarded<
      std::map<std::string, int64_t>>("alertCounts", [&]() -> Result<std::map<std::string, int64_t>> {
    std::map<std::string, int64_t> out;
    for (auto s : {AlertStatus::Open, AlertStatus::Acknowledged, AlertStatus::Invalid, AlertStatus::Fixed})
      out[toString(s)] = 0;
    Statement query(
        db_,
        "SELECT status, COUNT(*) FROM alerts WHERE (CAST(?1 AS BIGINT) IS NULL OR baseline_id = ?1) "
        "GROUP BY status");
    query.bind(1, baselineId);
    while (query.step()) {
      RowReader row(query);
      std::string status = row.getText();
      out[status] = row.getInt();
      row.end();
    }
    return out;
  });
}

Result<std::optional<Alert>> Alerts::setStatus(int64_t id, AlertStatus status) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<Alert>>("setAlertStatus", [&]() -> Result<std::optional<Alert>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(
        db_, std::string("UPDATE alerts SET status = ?1, updated_at = ") + nowSql(*db_) + " WHERE id = ?2");
    update.bind(1, toString(status)).bind(2, id).run();
    auto out = findAlert(db_, id);
    tx.commit();
    return out;
  });
}

Result<std::vector<Alert>> Alerts::configurationAlerts(int64_t baselineId, int limit) {
  if (limit < 1) return makeError("limit: must be at least 1");
  std::lock_guard lock(mutex_);
  return guarded<std::vector<Alert>>("configurationAlerts", [&]() -> Result<std::vector<Alert>> {
    // The alerts of every baseline of this baseline's configuration (one
    // configuration may have had several baselines over time).
    Statement query(
        db_, std::string("SELECT ") + kAlertColumns +
                 " FROM alerts a WHERE a.baseline_id IN (SELECT o.id FROM baselines o JOIN baselines b "
                 "ON o.renderer = b.renderer AND o.options = b.options AND o.scene_id = b.scene_id AND "
                 "o.width = b.width AND o.height = b.height AND o.device_id = b.device_id AND "
                 "o.counting = b.counting WHERE b.id = ?1) ORDER BY a.id DESC LIMIT ?2");
    query.bind(1, baselineId).bind(2, limit);
    std::vector<Alert> out;
    while (query.step()) out.push_back(readAlert(query));
    std::reverse(out.begin(), out.end());
    return out;
  });
}

// ---- the webhook's outbox --------------------------------------------------------------

Result<std::vector<Alert>> Alerts::claimDeliveries(int limit, int64_t claimMs) {
  if (limit < 1 || claimMs < 1) return makeError("claimDeliveries: limit and claim must be positive");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::vector<Alert>>("claimDeliveries", [&]() -> Result<std::vector<Alert>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement pick(db_,
                   std::string("SELECT id FROM alerts WHERE delivery = 'pending' AND next_attempt_ms <= ") +
                       nowMsSql(*db_) + " ORDER BY id LIMIT ?1" + skipLockedSql(*db_));
    pick.bind(1, limit);
    std::vector<int64_t> ids;
    while (pick.step()) ids.push_back(pick.getInt(0));
    Statement claim(
        db_, std::string("UPDATE alerts SET delivery_attempts = delivery_attempts + 1, next_attempt_ms = ") +
                 nowMsSql(*db_) + " + ?1 WHERE id = ?2");
    std::vector<Alert> out;
    for (int64_t id : ids) {
      claim.reset();
      claim.bind(1, claimMs).bind(2, id).run();
      out.push_back(findAlert(db_, id).value());
    }
    tx.commit();
    return out;
  });
}

Result<bool> Alerts::finishDelivery(int64_t id, bool delivered, const std::string& error,
                                    std::optional<int64_t> retryInMs) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("finishDelivery", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    std::string sql;
    if (delivered) {
      sql = std::string("UPDATE alerts SET delivery = 'delivered', delivered_at = ") + nowSql(*db_) +
            ", next_attempt_ms = NULL, delivery_error = NULL WHERE id = ?1 AND delivery = 'pending'";
    } else if (retryInMs) {
      sql = std::string("UPDATE alerts SET delivery_error = ?2, next_attempt_ms = ") + nowMsSql(*db_) +
            " + ?3 WHERE id = ?1 AND delivery = 'pending'";
    } else {
      sql =
          "UPDATE alerts SET delivery = 'failed', delivery_error = ?2, next_attempt_ms = NULL "
          "WHERE id = ?1 AND delivery = 'pending'";
    }
    Statement update(db_, sql);
    update.bind(1, id);
    if (!delivered) update.bind(2, error);
    if (!delivered && retryInMs) update.bind(3, *retryInMs);
    update.run();
    bool changed = db_->changes() > 0;
    tx.commit();
    return changed;
  });
}

}  // namespace tally::store
