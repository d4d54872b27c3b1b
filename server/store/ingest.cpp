// ingestCapture: one capture result (docs/result-schema.md) -> rows
// (ingest_capture.cpp), and ingestSweep: one sweep result -> a sweeps row;
// each in one write transaction. Bad input throws IngestError naming the
// JSON path; the transaction then rolls back, so nothing of the job is
// half-written.
#include <algorithm>
#include <stdexcept>

#include "common/json_fields.hpp"
#include "store/ingest_input.hpp"
#include "store/internal.hpp"

namespace tally::store {

using nlohmann::json;

namespace {

using detail::bad;
using detail::IngestError;
using detail::kMembers;
using json_fields::find;

}  // namespace

namespace detail {

int64_t insertDevice(Connection* db, const json& result) {
  const json* device = find(result, "device");
  if (!device || !device->is_object()) bad("device", "missing or not an object");
  std::string name = kMembers.text(*device, "name", "device");
  std::string vendor = kMembers.optText(*device, "vendorID", "device").value_or("");
  std::string deviceId = kMembers.optText(*device, "deviceID", "device").value_or("");
  std::string driver = kMembers.optText(*device, "driverInfo", "device").value_or("");
  std::string api = kMembers.optText(*device, "apiVersion", "device").value_or("");
  // Unit separators keep the fields apart whatever they contain.
  std::string fingerprint = name + '\x1f' + vendor + '\x1f' + deviceId + '\x1f' + driver + '\x1f' + api;
  // Most ingests find their device stored: a plain read then, so that
  // concurrent ingests (a fleet of one GPU model) do not queue on the
  // upsert's row lock.
  Statement stored(db, "SELECT id FROM devices WHERE fingerprint = ?1 AND info = ?2");
  stored.bind(1, fingerprint).bind(2, *device);
  if (stored.step()) {
    int64_t id = stored.getInt(0);
    stored.run();
    return id;
  }
  Statement upsert(db,
                   "INSERT INTO devices (fingerprint, name, vendor, driver, api_version, features, info) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) ON CONFLICT (fingerprint) DO UPDATE SET info = "
                   "excluded.info RETURNING id");
  upsert.bind(1, fingerprint)
      .bind(2, name)
      .bind(3, vendor)
      .bind(4, driver)
      .bind(5, api)
      .bind(6, kMembers.object(*device, "features", "device"))
      .bind(7, *device);
  if (!upsert.step()) throw IngestError("no id returned");
  int64_t id = upsert.getInt(0);
  upsert.run();
  return id;
}

}  // namespace detail

namespace {

using detail::insertDevice;
using detail::storeCapture;

// The sweep's row for a job, replacing an earlier one; inside the caller's transaction.
int64_t storeSweep(Connection* db, int64_t jobId, const json& result) {
  // Idempotency, as for captures: the job's result replaces its earlier one.
  Statement drop(db, "DELETE FROM sweeps WHERE job_id = ?1");
  drop.bind(1, jobId).run();
  int64_t deviceId = insertDevice(db, result);
  const json& failsAt = result["fails_at"];
  Statement insert(db,
                   "INSERT INTO sweeps (job_id, device_id, name, parameters, threshold, fails_at, point_count, "
                   "result) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) RETURNING id");
  insert.bind(1, jobId)
      .bind(2, deviceId)
      .bind(3, result["sweep"].get<std::string>())
      .bind(4, result["parameters"])
      .bind(5, result["threshold"])
      .bind(6, failsAt.is_null() ? std::optional<json>() : std::optional<json>(failsAt))
      .bind(7, static_cast<int64_t>(result["points"].size()))
      .bind(8, result);
  if (!insert.step()) throw IngestError("no id returned");
  int64_t id = insert.getInt(0);
  insert.run();
  return id;
}

bool jobExists(Connection* db, int64_t jobId) {
  Statement job(db, "SELECT 1 FROM jobs WHERE id = ?1");
  job.bind(1, jobId);
  bool found = job.step();
  job.run();
  return found;
}

}  // namespace

Result<int64_t> Runs::ingestSweep(int64_t jobId, const json& result) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the sweep result", [&]() -> Result<int64_t> {
    detail::checkSweep(result);
    Transaction tx(db_, Transaction::Kind::Write);
    if (!jobExists(db_, jobId)) return makeError("job " + std::to_string(jobId) + " not found");
    int64_t id = storeSweep(db_, jobId, result);
    tx.commit();
    return id;
  });
}

Result<int64_t> Runs::ingestSweep(const Lease& lease, const json& result) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the sweep result", [&]() -> Result<int64_t> {
    detail::checkSweep(result);
    Transaction tx(db_, Transaction::Kind::Write);
    if (!detail::holdsLease(db_, lease)) return makeError(detail::lostLease(db_, lease));
    int64_t id = storeSweep(db_, lease.jobId, result);
    detail::finishHeld(db_, lease, JobStatus::Done, std::nullopt);
    tx.commit();
    return id;
  });
}

// PostgreSQL plans statements from the tables' statistics, which autovacuum
// refreshes at most once a minute. Ingests that grow a young database many
// times over within that minute leave it planning for nearly empty tables:
// 20,000 samples stored in 10 s into a new database, and a run's samples
// took 1.1 s a request (sequential scans of the counters table it had then)
// until the statistics caught up, 1 ms after. So the store asks for the
// growing tables' statistics (StatisticsKeeper, on a connection and thread of
// its own, which no ingest waits for) whenever the samples it stored since
// it last asked reach the samples the database held at the last ANALYZE, and
// at least kAnalyzeEvery: a few times while a database grows from nothing,
// rarely after (a doubling each time).
constexpr int64_t kAnalyzeEvery = 5000;

void Runs::keepStatisticsCurrent(const json& result) {
  if (db_->engine() != Engine::Postgres) return;
  int64_t samples = 0;
  if (const json* runs = json_fields::find(result, "runs"); runs && runs->is_array()) {
    for (const json& run : *runs) {
      if (const json* s = json_fields::find(run, "samples"); s && s->is_array()) samples += int64_t(s->size());
    }
  }
  shared_.samplesSinceAnalyze += samples;
  if (!shared_.statistics) shared_.statistics = std::make_unique<StatisticsKeeper>(location_);
  int64_t held = shared_.statistics->state().samplesAtAnalyze;
  if (shared_.samplesSinceAnalyze < std::max(kAnalyzeEvery, held)) return;
  shared_.statistics->request();
  shared_.samplesSinceAnalyze = 0;
}

void Runs::waitForStatistics() {
  std::lock_guard lock(mutex_);
  if (shared_.statistics) shared_.statistics->waitIdle();
}

Result<int64_t> Runs::ingestCapture(int64_t jobId, const json& result,
                                    const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the capture result", [&]() -> Result<int64_t> {
    Transaction tx(db_, Transaction::Kind::Write);
    if (!jobExists(db_, jobId)) return makeError("job " + std::to_string(jobId) + " not found");
    int64_t runs = storeCapture(db_, jobId, result, screenshots, std::nullopt);
    tx.commit();
    keepStatisticsCurrent(result);
    return runs;
  });
}

Result<int64_t> Runs::ingestCapture(const Lease& lease, const json& result,
                                    const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the capture result", [&]() -> Result<int64_t> {
    Transaction tx(db_, Transaction::Kind::Write);
    if (!detail::holdsLease(db_, lease)) return makeError(detail::lostLease(db_, lease));
    int64_t runs = storeCapture(db_, lease.jobId, result, screenshots, lease.host);
    detail::finishHeld(db_, lease, JobStatus::Done, std::nullopt);
    tx.commit();
    keepStatisticsCurrent(result);
    return runs;
  });
}

}  // namespace tally::store
