// Tally's store: capture jobs (a persistent queue), ingested capture
// results, and the queries the service layer turns into JSON. One interface
// over two engines (db.hpp): a SQLite file, the default for one host, or a
// PostgreSQL database that a fleet of daemons shares (docs/fleet.md).
//
// Connections and threads. A Store is one connection; its calls are
// serialised by a mutex, so sharing one between threads is safe but slow.
// The daemon opens:
//   - one writer:  Store::open(path)            migrates, then takes writes;
//   - one reader per thread (HTTP workers):  Store::open(path, {.readOnly = true})
//     after the writer has migrated. Readers never block the writer (WAL) and
//     read a consistent snapshot per call; busy_timeout covers the moments
//     (WAL recovery, checkpoints) when SQLite briefly makes them wait.
// All write transactions in the process are additionally serialised by one
// process-wide mutex (one writer), and use BEGIN IMMEDIATE, so two processes
// on one file wait on busy_timeout instead of failing. On PostgreSQL the same
// shape holds (a writer that migrates, readers per thread) without the
// process-wide mutex: the server orders concurrent writers.
//
// Errors come back as tally::Result with a one-line reason; "not found" is an
// empty optional, not an error.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/db.hpp"
#include "store/fault.hpp"
#include "store/job_records.hpp"

namespace tally::store {

// ---- runs, samples ------------------------------------------------------------

struct Device {
  int64_t id = 0;
  std::string name, vendor, driver, apiVersion;
  nlohmann::json features;  // the result's device.features
  nlohmann::json info;      // the whole device object
};

struct RunFilter {
  std::optional<std::string> renderer;
  std::optional<std::string> variant;  // exact variant label ("visbuffer barycentrics=float32")
  std::optional<std::string> scene;  // scene name
  std::optional<int> width;
  std::optional<int> height;
  std::optional<int64_t> deviceId;
  std::optional<std::string> deviceName;  // exact device name
  std::optional<int64_t> jobId;
  std::optional<std::string> host;  // exact host name
  // Every one of these labels (name, value), exactly (0009): the capture's spec "labels".
  std::vector<std::pair<std::string, std::string>> labels;
  std::vector<int64_t> runIds;  // any of these runs (at most 1000); empty: any run
  // Creation time bounds, as prefixes of the stored UTC ISO-8601 text
  // ("2026-11-21", "2026-11-21T06:30"): since is compared with created_at,
  // until with created_at cut to its length, so both ends are inclusive at the
  // precision given (until=2026-11-21 keeps the whole day).
  std::optional<std::string> createdSince;
  std::optional<std::string> createdUntil;
};

struct Page {
  int limit = 100;     // 1..1000
  std::string cursor;  // empty: first page; else a nextCursor from the previous page
};

struct RunRow {
  int64_t id = 0;
  int64_t jobId = 0;
  int64_t deviceId = 0;
  std::string deviceName;
  std::string renderer;
  std::string scene;
  nlohmann::json sceneParams;
  int width = 0, height = 0;
  std::string counting;
  int lights = 0;
  std::optional<int64_t> renderTargetBytes;
  nlohmann::json notes;
  std::string createdAt;
  int sampleCount = 0;
  std::optional<double> meanFrameMs;  // over the run's samples
  std::optional<double> meanBytes;    // all counters per frame, over the run's samples
  std::optional<double> meanFrameMsInstrumented;  // a counted frame, over the samples
  std::optional<double> meanOverheadRatio;        // instrumented / uninstrumented frame time, over the samples
  // Image error against the reference (forward) over the samples compared:
  // how many were compared and how many were identical; PSNR (dB) over those
  // that differ, absent when none differs.
  int imageCompared = 0;
  int imageIdentical = 0;
  std::optional<double> meanPsnr;
  std::optional<double> minPsnr;
  // The renderer's canonical options ({} for the renderer as it is) and the
  // variant's label; runs stored before variants are their renderer.
  nlohmann::json options = nlohmann::json::object();
  std::string variant;
  // The Tally build that made the run; absent for runs stored before 0005.
  std::optional<std::string> tallyVersion, tallyCommit;
  // Footprint (0006): the block size the run counted it in (absent: off, or
  // stored before), and over the samples that have one, the mean footprint
  // per frame and the mean requested bytes of the lines that have a footprint
  // (reuse = footprintRequested / footprint). Absent when no sample has one.
  std::optional<int64_t> footprintBlockBytes;
  std::optional<double> meanFootprintBytes, meanFootprintRequestedBytes;
  std::optional<std::string> host;  // the host it was captured on (0007); absent before
  nlohmann::json labels = nlohmann::json::object();  // its capture's labels (0009); {} for none
};

struct RunPage {
  std::vector<RunRow> runs;  // newest first (descending id)
  std::string nextCursor;    // empty when this was the last page
};

struct RunResource {
  std::string name, kind;
  std::optional<std::string> format;
  std::optional<int64_t> elementBytes, width, height, allocationBytes, formatBytes;
  std::optional<std::string> usage;
};

struct Run {
  RunRow row;
  Device device;
  std::vector<RunResource> resources;  // in the result's order
  nlohmann::json shaders;              // shader source hashes of the capture
  nlohmann::json counterHeadroom;      // the result's counter_headroom; null when not stored
  // The device's ceilings measured by the run's capture (its samples'
  // extras.roofline.ceilings); null when not measured or not stored.
  nlohmann::json ceilings;
};

struct ImageError {
  std::string against;
  bool identical = false;
  std::optional<double> psnr;  // absent when identical
  double maxAbs = 0, meanAbs = 0;
};

struct SampleRow {
  int64_t id = 0;
  int64_t runId = 0;
  int cameraIndex = 0;
  nlohmann::json camera;
  std::optional<double> skyFraction;  // absent when the renderer has no skybox pass
  std::optional<double> skyFractionEstimate;
  std::optional<int> frames;
  double frameMs = 0;
  nlohmann::json frameMsSpread;  // null when absent
  std::optional<double> frameMsInstrumented;
  std::optional<double> overheadRatio;
  double bytes = 0;  // all counters of the sample, per frame
  double bytesRead = 0, bytesWritten = 0;  // its read and write counters, per frame
  std::optional<ImageError> imageError;
  bool hasScreenshot = false;
  nlohmann::json extras = nlohmann::json::object();  // technique measurements of the sample
  std::optional<ImageError> variantError;  // against the run's reference variant
  // The footprint of the sample's lines that have one, and those lines'
  // requested bytes, per frame; absent when no line has a footprint.
  std::optional<double> footprintBytes, footprintRequestedBytes;
  // Every uninstrumented frame's time (ms), in frame order (0008): filled by
  // getSample only; empty when not stored (older rows, results without it).
  std::vector<double> frameMsFrames;
};

struct Counter {
  std::string resource;
  std::optional<std::string> kind, format;
  std::string access;  // read | write
  double count = 0;    // per frame
  double bytes = 0;    // per frame
  nlohmann::json countSpread;
  std::string source;  // counter | derived
  std::optional<double> footprintBytes;  // distinct bytes touched per frame; absent where not measured
};

struct Pass {
  std::string name;
  double gpuMs = 0;
  nlohmann::json gpuMsSpread;
  std::optional<double> gpuMsInstrumented;
  std::optional<double> overheadRatio;
  std::optional<double> fragmentInvocations;
  std::optional<double> fragmentInvocationsStatistic;
  std::vector<Counter> counters;  // in the result's order
  // Passes that dispatch compute work; empty for the others.
  std::optional<double> computeInvocations;
  std::optional<double> computeInvocationsStatistic;
  // The pass's time (ms) in each of the sample's uninstrumented frames, in
  // frame order (0008): filled by getSample only; empty when not stored.
  std::vector<double> gpuMsFrames;
};

struct Sample {
  SampleRow row;
  std::vector<Pass> passes;  // in frame order
};

// ---- sweeps --------------------------------------------------------------------

struct SweepFilter {
  std::optional<std::string> name;  // the sweep's name, e.g. "depth-reconstruction"
  std::optional<int64_t> deviceId;
  std::optional<std::string> deviceName;  // exact device name
  std::optional<int64_t> jobId;
  // As RunFilter's: prefixes of the stored UTC ISO-8601 text, both inclusive.
  std::optional<std::string> createdSince;
  std::optional<std::string> createdUntil;
};

struct SweepRow {
  int64_t id = 0;
  int64_t jobId = 0;
  Device device;
  std::string name;
  nlohmann::json parameters;  // array of axis names
  nlohmann::json threshold;   // as the result gave it
  nlohmann::json failsAt;     // null when no point reaches the threshold
  int64_t pointCount = 0;
  std::string createdAt;
};

struct SweepPage {
  std::vector<SweepRow> sweeps;  // newest first (descending id)
  std::string nextCursor;        // empty when this was the last page
};

struct Sweep {
  SweepRow row;
  nlohmann::json result;  // the whole result, as ingested
};

// ---- compare, export ----------------------------------------------------------

// One quantity for one run, against the first run of the comparison.
struct Compared {
  std::optional<double> value;  // absent when the run does not have this pass/resource
  std::optional<double> delta;  // value - first's value (both present)
  std::optional<double> ratio;  // value / first's value (both present, first non-zero)
};

// Values are per frame, averaged over the run's samples (a sample without the
// pass/resource counts as 0); one entry per compared run, in the order asked.
struct PassComparison {
  std::string pass;
  std::vector<Compared> gpuMs;
  std::vector<Compared> bytes;  // all of the pass's counters (requested bytes)
  std::vector<Compared> fragmentInvocations;
  // The footprint of the counters that have one (absent for a run without),
  // and reuse: those counters' requested bytes / their footprint.
  std::vector<Compared> footprintBytes;
  std::vector<Compared> reuse;
};

struct ResourceComparison {
  std::string resource;
  std::string access;  // read | write
  std::vector<Compared> count;
  std::vector<Compared> bytes;  // summed over passes (requested bytes)
  std::vector<Compared> footprintBytes;  // summed over passes; absent for a run without
  std::vector<Compared> reuse;           // as PassComparison's
};

struct Comparison {
  std::vector<RunRow> runs;
  std::vector<Compared> frameMs;
  std::vector<Compared> totalBytes;
  std::vector<Compared> totalFootprintBytes;  // every counter that has one; absent for a run without
  std::vector<Compared> reuse;                // those counters' requested bytes / their footprint
  std::vector<PassComparison> passes;         // first run's frame order, then others' new passes
  std::vector<ResourceComparison> resources;  // by resource name, then access
};

// One row per run x pass x resource x access; count and bytes per frame,
// averaged over the run's samples.
struct ExportRow {
  int64_t runId = 0;
  std::string renderer, scene;
  int width = 0, height = 0;
  std::string device, pass, resource, access;
  double count = 0, bytes = 0;
  // The footprint of the row's counters that have one, and their requested
  // bytes (reuse = footprintRequestedBytes / footprintBytes); absent without.
  std::optional<double> footprintBytes, footprintRequestedBytes;
};

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
// change). Called by evaluatePendingRuns (on PostgreSQL inside its write
// transaction), so it must read through another connection, never this Store.
using RunEvaluator = std::function<Result<std::vector<NewAlert>>(const RunRow& run, const Baseline& baseline)>;

struct Evaluated {
  int64_t runs = 0;               // runs marked evaluated
  int64_t tested = 0;             // of those, runs with a baseline to test against
  std::vector<int64_t> alertIds;  // the alerts raised
};

// ---- the store ----------------------------------------------------------------

class Store {
 public:
  struct Options {
    bool readOnly = false;     // a reader: no migrations, no writes (PRAGMA query_only)
    int busyTimeoutMs = 5000;  // how long to wait on another connection's lock
  };

  // Opens (creating when writable) and migrates. location is a SQLite file
  // path or a postgresql:// URL (isPostgresUrl). Refuses a database whose
  // schema is newer than this binary's, naming both versions.
  static Result<std::unique_ptr<Store>> open(const std::string& location, Options options);
  static Result<std::unique_ptr<Store>> open(const std::string& location) { return open(location, Options{}); }
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  int schemaVersion() const { return schemaVersion_; }

  // Jobs (the persistent queue; the worker drives the transitions).
  // A repeated idempotency key returns the existing job (created = false).
  // The spec's "device" is stored as its requirement (an error names a bad one).
  Result<CreatedJob> createJob(const nlohmann::json& spec, std::optional<std::string> idempotencyKey = {},
                               int maxAttempts = 3);
  // As above, refused (CreatedJob::refused) when a limit is reached; a
  // repeated idempotency key returns its job whatever the limits.
  Result<CreatedJob> createJob(const nlohmann::json& spec, std::optional<std::string> idempotencyKey,
                               int maxAttempts, const QueueLimits& limits);
  // Oldest queued job -> running, attempts + 1, started_at, worker_pid; empty when none.
  Result<std::optional<Job>> claimNextJob(int64_t workerPid = 0);
  // The oldest queued job whose device requirement the claimer's device
  // meets -> running, held by claimer.host under a lease of leaseMs. On
  // PostgreSQL the candidates are locked FOR UPDATE SKIP LOCKED, so claimers
  // on many hosts never take one job twice and never wait on each other.
  Result<std::optional<Job>> claimNextJob(const Claimer& claimer);
  // Extends the lease; false when the job is no longer held under `lease`
  // (cancelled, or expired and claimed again): stop working on it.
  Result<bool> renewLease(const Lease& lease, int64_t leaseMs);
  // Running jobs whose lease ended (their host died or lost the database):
  // queued again with the reason in attempt_errors, or failed with every
  // reason once max_attempts claims were used.
  Result<Recovery> requeueExpired();
  // False when the job is no longer running (cancelled meanwhile): stop working on it.
  Result<bool> updateProgress(int64_t jobId, int64_t done, int64_t total,
                              std::optional<std::string> current = {});
  // running -> done | failed (with error). False when the job was not running
  // (e.g. cancelled meanwhile: it stays cancelled).
  Result<bool> finishJob(int64_t jobId, JobStatus status, std::optional<std::string> error = {});
  // As above, only while `lease` holds the job; counts the job on the host.
  Result<bool> finishJob(const Lease& lease, JobStatus status, std::optional<std::string> error = {});
  // running -> queued while `lease` holds the job, when its host stops before
  // the job ends (tallyd serve's shutdown): the claim is given back
  // (attempts - 1, so a stop does not count towards max_attempts) and
  // `reason` is added to attempt_errors. False when the lease no longer holds it.
  Result<bool> requeueJob(const Lease& lease, const std::string& reason);
  // queued | running -> cancelled; a finished job is returned unchanged. Empty: no such job.
  Result<std::optional<Job>> cancelJob(int64_t jobId);
  // Jobs by status ("queued", "running", "done", "failed", "cancelled"), each present.
  Result<std::map<std::string, int64_t>> jobCounts();
  Result<std::optional<Job>> getJob(int64_t jobId);
  // Newest first, cursor-paginated like listRuns; status empty: every status.
  Result<JobPage> listJobs(std::optional<JobStatus> status, const Page& page);
  // Start-up recovery: every running job (of `host`, when given: other
  // hosts' jobs are theirs) goes back to queued when attempts < maxAttempts,
  // else to failed with "interrupted N times".
  Result<Recovery> requeueInterrupted(int maxAttempts, std::optional<std::string> host = {});

  // Hosts. Registers (or re-registers) a worker under its name; refused
  // while another live instance (heartbeat within staleAfterMs) holds the name.
  // instanceIsGone: says whether a live-looking holder is in fact gone (the
  // same machine, its process dead: a restart after a crash need not wait).
  Result<bool> registerHost(const HostInfo& info, int64_t staleAfterMs,
                            const std::function<bool(const std::string&)>& instanceIsGone = {});
  // The host's heartbeat and current job; false when another instance took the name.
  Result<bool> heartbeat(const std::string& name, const std::string& instance, std::optional<int64_t> currentJob);
  // Every host by name, alive when its heartbeat is within staleAfterMs.
  Result<std::vector<Host>> listHosts(int64_t staleAfterMs);

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
  Result<std::vector<Device>> listDevices();
  Result<RunPage> listRuns(const RunFilter& filter, const Page& page);
  Result<std::optional<Run>> getRun(int64_t runId);
  // Empty vector for an unknown run or one without samples.
  Result<std::vector<SampleRow>> listSamples(int64_t runId);
  Result<std::optional<Sample>> getSample(int64_t sampleId);
  // A run's passes and per-resource counters, per frame, averaged over its
  // samples as compareRuns does (a sample without a pass or counter counts as
  // 0; overhead ratios are the mean of the samples that have one); spreads
  // are null. Empty for an unknown run or one without samples.
  Result<std::vector<Pass>> runPasses(int64_t runId);
  // Empty: no such sample, or it has no screenshot.
  Result<std::optional<std::vector<uint8_t>>> getScreenshot(int64_t sampleId);
  // 2..4 distinct existing run ids; deltas and ratios against the first.
  Result<Comparison> compareRuns(const std::vector<int64_t>& runIds);
  // Sweeps, newest first, cursor-paginated like listRuns.
  Result<SweepPage> listSweeps(const SweepFilter& filter, const Page& page);
  Result<std::optional<Sweep>> getSweep(int64_t sweepId);
  // The sweeps a job stored (one for a finished sweep job, none otherwise), by id.
  Result<std::vector<int64_t>> jobSweepIds(int64_t jobId);
  // Rows for CSV/JSON export, ordered by run id, pass order, resource, access.
  Result<std::vector<ExportRow>> exportRuns(const RunFilter& filter);

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

  // Alerts. Takes up to `limit` runs not yet evaluated, tests each run that
  // has an active baseline older than it with `evaluate`, inserts the alerts
  // (delivery pending when `deliver`, else none) and marks the runs
  // evaluated. On PostgreSQL the runs are claimed FOR UPDATE SKIP LOCKED and
  // all of it is one transaction: two daemons never test one run. On SQLite
  // the runs are tested before the write transaction (the file's one write
  // lock is not held while they are), which then marks each run still
  // unevaluated and stores its alerts: a run raises its alerts once. An
  // evaluator error stores nothing of the pass.
  Result<Evaluated> evaluatePendingRuns(const RunEvaluator& evaluate, int limit, bool deliver);
  Result<AlertPage> listAlerts(const AlertFilter& filter, const Page& page);
  Result<std::optional<Alert>> getAlert(int64_t alertId);
  // Alerts by status, each status present; for `baselineId` only when given.
  Result<std::map<std::string, int64_t>> alertCounts(std::optional<int64_t> baselineId = {});
  // Empty: no such alert.
  Result<std::optional<Alert>> setAlertStatus(int64_t alertId, AlertStatus status);
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

  // SQLite: PRAGMA integrity_check's first line ("ok" when healthy) and no
  // foreign key violations. PostgreSQL enforces both as it writes: "ok" when
  // the server answers.
  Result<std::string> integrityCheck();
  // The store's health check, cheap enough to run on a schedule: SQLite's
  // PRAGMA quick_check (its first three lines; "ok" when healthy; O(N) in the
  // file's size, without integrity_check's index cross-checks), PostgreSQL's
  // round trip ("ok" when the server answers). Run it on a connection of its
  // own: it holds this one for as long as it reads.
  Result<std::string> quickCheck();
  // Whether the store takes a write again (after a full disk): SQLite
  // rewrites one header field with its own value and commits; PostgreSQL
  // answers a round trip.
  Result<bool> probeWrite();

  // The connection, for tests and tools; not for concurrent use.
  Connection& connection() { return *db_; }
  Engine engine() const { return db_->engine(); }

 private:
  Store(std::unique_ptr<Connection> db, int version)
      : owner_(std::move(db)), db_(owner_.get()), schemaVersion_(version) {}
  std::unique_ptr<Connection> owner_;
  Connection* db_;
  int schemaVersion_;
  std::mutex mutex_;  // one call at a time on this connection
};

// Cursor encoding for listRuns, listSweeps and listJobs ("r" + last id in hex; opaque to clients).
std::string encodeCursor(int64_t lastId);
std::optional<int64_t> decodeCursor(std::string_view cursor);

}  // namespace tally::store
