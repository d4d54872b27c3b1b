// The job queue, a facet of the Store (store.jobs()): jobs are created by
// the service, claimed by workers under leases, and end done, failed or
// cancelled (docs/fleet.md). Every transition is one write transaction.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/facet.hpp"
#include "store/job_records.hpp"
#include "store/run_records.hpp"

namespace tally::store {

class JobQueue : public Facet {
 public:
  // The worker drives the transitions.
  // A repeated idempotency key returns the existing job (created = false).
  // The spec's "device" is stored as its requirement (an error names a bad one).
  Result<CreatedJob> create(const nlohmann::json& spec, std::optional<std::string> idempotencyKey = {},
                            int maxAttempts = 3);
  // As above, refused (CreatedJob::refused) when a limit is reached; a
  // repeated idempotency key returns its job whatever the limits.
  Result<CreatedJob> create(const nlohmann::json& spec, std::optional<std::string> idempotencyKey,
                            int maxAttempts, const QueueLimits& limits);
  // Oldest queued job -> running, attempts + 1, started_at, worker_pid; empty when none.
  Result<std::optional<Job>> claim(int64_t workerPid = 0);
  // The oldest queued job whose device requirement the claimer's device
  // meets -> running, held by claimer.host under a lease of leaseMs. On
  // PostgreSQL the candidates are locked FOR UPDATE SKIP LOCKED, so claimers
  // on many hosts never take one job twice and never wait on each other.
  Result<std::optional<Job>> claim(const Claimer& claimer);
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
  Result<bool> finish(int64_t jobId, JobStatus status, std::optional<std::string> error = {});
  // As above, only while `lease` holds the job; counts the job on the host.
  Result<bool> finish(const Lease& lease, JobStatus status, std::optional<std::string> error = {});
  // running -> queued while `lease` holds the job, when its host stops before
  // the job ends (tallyd serve's shutdown): the claim is given back
  // (attempts - 1, so a stop does not count towards max_attempts) and
  // `reason` is added to attempt_errors. False when the lease no longer holds it.
  Result<bool> requeue(const Lease& lease, const std::string& reason);
  // queued | running -> cancelled; a finished job is returned unchanged. Empty: no such job.
  Result<std::optional<Job>> cancel(int64_t jobId);
  // Jobs by status ("queued", "running", "done", "failed", "cancelled"), each present.
  Result<std::map<std::string, int64_t>> counts();
  Result<std::optional<Job>> get(int64_t jobId);
  // Newest first, cursor-paginated like Runs::list; status empty: every status.
  Result<JobPage> list(std::optional<JobStatus> status, const Page& page);
  // Start-up recovery: every running job (of `host`, when given: other
  // hosts' jobs are theirs) goes back to queued when attempts < maxAttempts,
  // else to failed with "interrupted N times".
  Result<Recovery> requeueInterrupted(int maxAttempts, std::optional<std::string> host = {});

 private:
  friend class Store;
  explicit JobQueue(Shared& shared) : Facet(shared) {}
};

}  // namespace tally::store
