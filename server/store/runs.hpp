// Stored results, a facet of the Store (store.runs()): ingesting capture
// and sweep results, and the queries over runs, samples, sweeps and devices.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/facet.hpp"
#include "store/job_records.hpp"
#include "store/run_records.hpp"
#include "store/site_records.hpp"

namespace tally::store {

class Runs : public Facet {
 public:
  // Stores a whole capture result (docs/result-schema.md) for a job, in one
  // transaction: all of it or none of it. Idempotent: the job's previously
  // ingested runs (and their screenshots) are replaced, so ingesting the same
  // result twice stores it once. screenshots maps a sample's "screenshot" file
  // name to its PNG bytes; a named screenshot missing from the map, or not a
  // PNG, is an error. Does not change the job's status. Returns the number of
  // runs stored.
  Result<int64_t> ingestCapture(int64_t jobId, const nlohmann::json& result,
                                const std::map<std::string, std::vector<uint8_t>>& screenshots);
  // A worker's ingest: the same, only while `lease` holds the job, with the
  // runs stamped with lease.host, and the job finished as done (and counted
  // on its host) in the same transaction: a job is done exactly when its
  // result is stored, and an attempt that lost its lease stores nothing.
  Result<int64_t> ingestCapture(const Lease& lease, const nlohmann::json& result,
                                const std::map<std::string, std::vector<uint8_t>>& screenshots);

  // Stores a whole sweep result (docs/result-schema.md, "Sweep results") for
  // a job, in one transaction, after checking its frame: sweep, device,
  // parameters, points (each carrying every parameter and every field its
  // plots name), threshold, fails_at, plots. Bad input is an error naming the
  // field, and nothing is stored. Idempotent like ingestCapture: the job's
  // previous sweep is replaced. Does not change the job's status. Returns the
  // sweep's id.
  Result<int64_t> ingestSweep(int64_t jobId, const nlohmann::json& result);
  Result<int64_t> ingestSweep(const Lease& lease, const nlohmann::json& result);  // as ingestCapture(lease)

  // Queries.
  // Every device a capture was ingested from, by id.
  Result<std::vector<Device>> devices();
  Result<RunPage> list(const RunFilter& filter, const Page& page);
  Result<std::optional<Run>> get(int64_t runId);
  // A run with its passes (as passes() averages them) read in one
  // transaction: what GET /api/runs/{id} serves. Empty for an unknown run.
  Result<std::optional<RunDetail>> detail(int64_t runId);
  // Empty vector for an unknown run or one without samples.
  Result<std::vector<SampleRow>> samples(int64_t runId);
  Result<std::optional<Sample>> sample(int64_t sampleId);
  // Every sample's frame times, by camera, without its passes and counters
  // (a run's frame-time statistics, reports/frame_time.hpp). Empty for an
  // unknown run or one without samples.
  Result<std::vector<SampleFrameTimes>> sampleFrameTimes(int64_t runId);
  // The same for many runs in one statement (a listing's page), by run id;
  // a run without samples has no entry.
  Result<std::map<int64_t, std::vector<SampleFrameTimes>>> sampleFrameTimes(std::span<const int64_t> runIds);
  // A run's passes and per-resource counters, per frame, averaged over its
  // samples as compare() does (a sample without a pass or counter counts as
  // 0; overhead ratios are the mean of the samples that have one); spreads
  // are null. Empty for an unknown run or one without samples.
  Result<std::vector<Pass>> passes(int64_t runId);
  // Empty: no such sample, or it has no screenshot.
  Result<std::optional<std::vector<uint8_t>>> screenshot(int64_t sampleId);
  // 2..4 distinct existing run ids; deltas and ratios against the first.
  Result<Comparison> compare(const std::vector<int64_t>& runIds);
  // Sweeps, newest first, cursor-paginated like list().
  Result<SweepPage> sweeps(const SweepFilter& filter, const Page& page);
  Result<std::optional<Sweep>> sweep(int64_t sweepId);
  // The sweeps a job stored (one for a finished sweep job, none otherwise), by id.
  Result<std::vector<int64_t>> jobSweepIds(int64_t jobId);
  // Sites, draws and materials of a sample (0011; sites.cpp): ranked by
  // bytes and paged, with every pass's bytes for shares. Empty optional: no
  // such sample. A query's pass that the sample lacks selects no row.
  Result<std::optional<SitePage>> sites(int64_t sampleId, const SiteQuery& query);
  Result<std::optional<DrawPage>> draws(int64_t sampleId, const DrawQuery& query);
  // A run's shader sources by name, without their text; one with its text.
  Result<std::vector<ShaderSource>> shaderSources(int64_t runId);
  Result<std::optional<ShaderSource>> shaderSource(int64_t runId, const std::string& name);
  // PostgreSQL: blocks until the growing tables' statistics that ingests
  // asked for are current (their ANALYZE runs beside the ingests, which do
  // not wait for it; ingest.cpp). SQLite: returns at once.
  void waitForStatistics();
  // Rows for CSV/JSON export, ordered by run id, pass order, resource, access.
  Result<std::vector<ExportRow>> exportRows(const RunFilter& filter);

 private:
  friend class Store;
  explicit Runs(Shared& shared) : Facet(shared) {}
  void keepStatisticsCurrent(const nlohmann::json& result);
};

}  // namespace tally::store
