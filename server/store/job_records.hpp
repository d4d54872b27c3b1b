// The store's job and fleet records: the job queue's rows and states, device
// requirements, hosts and the leases workers claim jobs under. Kept apart from
// store.hpp so that code handling jobs reads them without the whole Store.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"

namespace tally::store {

// ---- jobs -------------------------------------------------------------------

// A job's states, named once: toString gives the wire's names
// (protocol.hpp: GET /api/captures/{id}'s "status"), which are also the
// jobs table's status column; the store's SQL and the service name states
// only through these.
enum class JobStatus { Queued, Running, Done, Failed, Cancelled };
inline constexpr JobStatus kJobStatuses[] = {JobStatus::Queued, JobStatus::Running, JobStatus::Done,
                                             JobStatus::Failed, JobStatus::Cancelled};
const char* toString(JobStatus status);  // "queued", "running", ...
std::optional<JobStatus> parseJobStatus(std::string_view name);
// Done, failed and cancelled are final: no transition leaves them.
constexpr bool isFinal(JobStatus status) {
  return status != JobStatus::Queued && status != JobStatus::Running;
}

struct Job {
  int64_t id = 0;
  JobStatus status = JobStatus::Queued;
  nlohmann::json spec;
  int64_t progressDone = 0;
  int64_t progressTotal = 0;
  std::optional<std::string> progressCurrent;  // e.g. "deferred atrium 320x180 camera 3"
  std::optional<std::string> error;
  int attempts = 0;  // times claimed by a worker
  std::optional<std::string> idempotencyKey;
  std::string createdAt;                 // UTC ISO-8601, e.g. 2026-11-21T06:30:00.123Z
  std::optional<std::string> startedAt;  // last claim
  std::optional<std::string> finishedAt;
  std::optional<int64_t> workerPid;
  // The fleet (0007): the host that holds the job (running) or last held it;
  // when the holder's lease ends unless renewed (ms since 1970, the
  // database's clock); claims allowed; why each earlier attempt ended (JSON
  // array of strings); the spec's device requirement, normalised (null: any).
  std::optional<std::string> host;
  std::optional<int64_t> leaseExpiresMs;
  int maxAttempts = 3;
  nlohmann::json attemptErrors = nlohmann::json::array();
  nlohmann::json deviceRequirement;
};

// ---- the fleet: device requirements, hosts, leases ---------------------------

// A spec's "device": a string (a substring of the device name) or
// {"name": substring, "vendor": "NVIDIA" | "0x10DE", "features": [names]}.
// Matching ignores case; features must be true in the device's "features".
struct DeviceRequirement {
  std::optional<std::string> name;
  std::optional<std::string> vendor;
  std::vector<std::string> features;
  nlohmann::json toJson() const;  // {"name"?, "vendor"?, "features"?}
};
// From spec["device"]; empty when the spec has none. Errors name the field.
Result<std::optional<DeviceRequirement>> parseDeviceRequirement(const nlohmann::json& spec);
Result<DeviceRequirement> deviceRequirementFromJson(const nlohmann::json& value);
// Why `device` (a result-style device object: name, vendorID, features) does
// not meet the requirement; empty when it does.
std::string deviceMismatch(const DeviceRequirement& requirement, const nlohmann::json& device);
// "NVIDIA" for "0x10DE", ... ; the id itself when unknown.
std::string vendorName(std::string_view vendorId);
// Milliseconds since 1970 (lease and heartbeat times) as UTC ISO-8601 text
// with milliseconds, as the store writes every other time.
std::string isoTimeFromMs(int64_t ms);

struct HostInfo {
  std::string name;      // unique in the store
  std::string instance;  // random per process
  std::string role;      // "worker" | "all"
  nlohmann::json device;  // result-style device object; null until probed
  std::optional<std::string> deviceOverride;
  std::string tallyVersion, tallyCommit;
};

struct Host {
  HostInfo info;
  std::string startedAt;
  std::string lastHeartbeat;  // UTC ISO-8601
  double secondsSinceHeartbeat = 0;
  bool alive = false;  // heartbeat within the stale limit
  int64_t jobsDone = 0, jobsFailed = 0;
  std::optional<int64_t> currentJob;
};

// What a worker offers when it claims.
struct Claimer {
  int64_t workerPid = 0;
  std::string host;       // empty: a single daemon without a host row
  nlohmann::json device;  // null: only jobs without a device requirement
  int64_t leaseMs = 30000;
};

// The claim a worker holds. Every write it makes for the job (renewals,
// progress, ingest, finish) is checked against it, so a worker whose lease
// expired and whose job was claimed again cannot store or finish it.
struct Lease {
  int64_t jobId = 0;
  int attempt = 0;
  std::string host;
};

struct CreatedJob {
  Job job;
  bool created = false;   // false: the idempotency key was seen before; job is that job
  bool conflict = false;  // the key was seen before with a different spec (job is the old one)
  // A QueueLimits limit was reached and nothing was stored: "queue" (the
  // store's queued jobs) or "client" (the client's); empty otherwise.
  std::string refused;
  int64_t queued = 0;  // when refused: the queued jobs counted against that limit
};

// Limits on queued jobs that JobQueue::create checks in the transaction that
// inserts, so concurrent requests (on PostgreSQL, of several API daemons)
// cannot overshoot them. 0: no limit.
struct QueueLimits {
  std::string client;     // who asks, stored with the job ("token:capture", "peer:127.0.0.1"); "": nobody
  int64_t maxQueued = 0;  // queued jobs in the store
  int64_t maxQueuedPerClient = 0;  // queued jobs of `client`
};

struct JobPage {
  std::vector<Job> jobs;   // newest first (descending id)
  std::string nextCursor;  // empty when this was the last page
};

struct Recovery {
  std::vector<int64_t> requeued;  // running -> queued
  std::vector<int64_t> failed;    // running -> failed: "interrupted N times"
};

}  // namespace tally::store
