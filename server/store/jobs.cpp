// The persistent job queue: transitions queued -> running -> done | failed,
// and queued | running -> cancelled. Each transition is one write transaction.
#include "store/internal.hpp"
#include "store/job_waiter.hpp"

namespace tally::store {

using detail::guarded;
using detail::kJobColumns;
using nlohmann::json;

namespace detail {

Job readJob(const Statement& statement) {
  RowReader row(statement);
  Job job;
  job.id = row.getInt();
  job.status = parseJobStatus(row.getText()).value_or(JobStatus::Failed);
  job.spec = row.getJson();
  job.progressDone = row.getInt();
  job.progressTotal = row.getInt();
  job.progressCurrent = row.getOptText();
  job.error = row.getOptText();
  job.attempts = static_cast<int>(row.getInt());
  job.idempotencyKey = row.getOptText();
  job.createdAt = row.getText();
  job.startedAt = row.getOptText();
  job.finishedAt = row.getOptText();
  job.workerPid = row.getOptInt();
  job.host = row.getOptText();
  job.leaseExpiresMs = row.getOptInt();
  job.maxAttempts = static_cast<int>(row.getInt());
  job.attemptErrors = row.getJson();
  job.deviceRequirement = row.getJson();
  row.end();
  return job;
}

}  // namespace detail

namespace {

// Statuses as SQL literals ('queued'): the SQL names them only through toString.
std::string quoted(JobStatus status) { return std::string("'") + toString(status) + "'"; }
const std::string kQueued = quoted(JobStatus::Queued), kRunning = quoted(JobStatus::Running),
                  kFailed = quoted(JobStatus::Failed), kCancelled = quoted(JobStatus::Cancelled);

std::optional<Job> findJob(Connection* db, int64_t id) {
  Statement query(db, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?1");
  query.bind(1, id);
  if (!query.step()) return std::nullopt;
  return detail::readJob(query);
}

// Reads the single row of an "... RETURNING" statement and finishes it.
// Commits a transaction that made jobs claimable, announcing them to idle
// workers (job_waiter.hpp): PostgreSQL's NOTIFY is sent inside the
// transaction and heard at its commit; SQLite's announcement, in-process, follows the commit.
void commitAnnouncing(Transaction& tx, Connection* db, const std::string& location) {
  if (db->engine() == Engine::Postgres) db->exec(std::string("NOTIFY ") + kJobChannel);
  tx.commit();
  if (db->engine() == Engine::Sqlite) detail::announceJobsInProcess(location);
}

std::optional<Job> returnedJob(Statement& statement) {
  std::optional<Job> job;
  if (statement.step()) job = detail::readJob(statement);
  statement.run();
  return job;
}

}  // namespace

Result<CreatedJob> JobQueue::create(const json& spec, std::optional<std::string> idempotencyKey,
                                    int maxAttempts) {
  return create(spec, std::move(idempotencyKey), maxAttempts, QueueLimits{});
}

Result<CreatedJob> JobQueue::create(const json& spec, std::optional<std::string> idempotencyKey,
                                    int maxAttempts, const QueueLimits& limits) {
  if (idempotencyKey && (idempotencyKey->empty() || idempotencyKey->size() > 255)) {
    return makeError("idempotency_key: must be 1 to 255 characters");
  }
  if (maxAttempts < 1) return makeError("max_attempts: must be at least 1");
  auto requirement = parseDeviceRequirement(spec);
  if (!requirement) return makeError(requirement.error());
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<CreatedJob>("createJob", [&]() -> Result<CreatedJob> {
    Transaction tx(db_, Transaction::Kind::Write);
    CreatedJob out;
    if (idempotencyKey) {
      Statement query(db_, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE idempotency_key = ?1");
      query.bind(1, *idempotencyKey);
      if (query.step()) {
        out.job = detail::readJob(query);
        out.conflict = out.job.spec != spec;
        return out;  // nothing written; the transaction rolls back
      }
    }
    if (limits.maxQueued > 0 || (limits.maxQueuedPerClient > 0 && !limits.client.empty())) {
      // Counted and inserted under one lock: SQLite's write transaction is
      // one already; PostgreSQL's API daemons take this advisory lock.
      if (db_->engine() == Engine::Postgres) {
        Statement serialise(db_, "SELECT pg_advisory_xact_lock(7310)");  // 7310: the queue's limits
        serialise.step();
        serialise.run();
      }
      if (limits.maxQueued > 0) {
        Statement count(db_, "SELECT count(*) FROM jobs WHERE status = " + kQueued);
        count.step();
        out.queued = count.getInt(0);
        count.run();
        if (out.queued >= limits.maxQueued) {
          out.refused = "queue";
          return out;
        }
      }
      if (limits.maxQueuedPerClient > 0 && !limits.client.empty()) {
        Statement count(db_, "SELECT count(*) FROM jobs WHERE client = ?1 AND status = " + kQueued);
        count.bind(1, limits.client);
        count.step();
        out.queued = count.getInt(0);
        count.run();
        if (out.queued >= limits.maxQueuedPerClient) {
          out.refused = "client";
          return out;
        }
      }
      out.queued = 0;
    }
    Statement insert(
        db_, std::string("INSERT INTO jobs (spec, idempotency_key, max_attempts, device_requirement, client) "
                         "VALUES (?1, ?2, ?3, ?4, ?5) RETURNING ") +
                 kJobColumns);
    insert.bind(1, spec).bind(2, idempotencyKey).bind(3, maxAttempts);
    insert.bind(5, limits.client.empty() ? std::optional<std::string>() : std::optional(limits.client));
    if (*requirement) {
      insert.bind(4, (*requirement)->toJson());
    } else {
      insert.bind(4, nullptr);
    }
    out.job = returnedJob(insert).value();
    // The spec's labels (checked by the service: an object of short strings);
    // anything else is not a label and is not stored as one.
    const json* labels = spec.is_object() && spec.contains("labels") ? &spec["labels"] : nullptr;
    if (labels && labels->is_object()) {
      json kept = json::object();
      Statement label(db_, "INSERT INTO job_labels (job_id, name, value) VALUES (?1, ?2, ?3)");
      for (const auto& [name, value] : labels->items()) {
        if (!value.is_string()) continue;
        label.reset();
        label.bind(1, out.job.id).bind(2, name).bind(3, value.get<std::string>()).run();
        kept[name] = value;
      }
      Statement setLabels(db_, "UPDATE jobs SET labels = ?1 WHERE id = ?2");
      setLabels.bind(1, kept).bind(2, out.job.id).run();
    }
    out.created = true;
    commitAnnouncing(tx, db_, location_);
    return out;
  });
}

Result<std::optional<Job>> JobQueue::claim(int64_t workerPid) {
  Claimer claimer;
  claimer.workerPid = workerPid;
  return claim(claimer);
}

Result<std::optional<Job>> JobQueue::claim(const Claimer& claimer) {
  if (claimer.leaseMs < 1) return makeError("lease: must be at least 1 ms");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<Job>>("claimNextJob", [&]() -> Result<std::optional<Job>> {
    Transaction tx(db_, Transaction::Kind::Write);
    // Candidates in queue order, a page at a time, filtered here by device;
    // only the one taken is locked, so other claimers pass over it and take
    // the next (SKIP LOCKED) instead of waiting.
    Statement page(db_, "SELECT id, device_requirement FROM jobs WHERE status = " + kQueued +
                            " AND id > ?1 "
                            "ORDER BY id LIMIT 64");
    Statement lockOne(
        db_, std::string("SELECT id FROM jobs WHERE id = ?1 AND status = " + kQueued) + skipLockedSql(*db_));
    std::optional<int64_t> chosen;
    int64_t after = 0;
    while (!chosen) {
      page.reset();
      page.bind(1, after);
      std::vector<std::pair<int64_t, json>> candidates;
      while (page.step()) {
        RowReader row(page);
        int64_t id = row.getInt();
        candidates.emplace_back(id, row.getJson());
        row.end();
      }
      if (candidates.empty()) break;
      after = candidates.back().first;
      for (const auto& [id, requirement] : candidates) {
        if (!requirement.is_null()) {
          if (claimer.device.is_null()) continue;
          auto parsed = deviceRequirementFromJson(requirement);
          if (!parsed || !deviceMismatch(*parsed, claimer.device).empty()) continue;
        }
        lockOne.reset();
        lockOne.bind(1, id);
        if (lockOne.step()) {
          lockOne.run();
          chosen = id;
          break;
        }
      }
    }
    if (!chosen) return std::optional<Job>();
    Statement claim(
        db_,
        std::string("UPDATE jobs SET status = " + kRunning + ", attempts = attempts + 1, started_at = ") +
            nowSql(*db_) +
            ", finished_at = NULL, error = NULL, progress_done = 0, progress_current = NULL, "
            "worker_pid = ?1, host = ?2, lease_expires_ms = " +
            nowMsSql(*db_) + " + ?3 WHERE id = ?4 RETURNING " + kJobColumns);
    claim.bind(1, claimer.workerPid > 0 ? std::optional<int64_t>(claimer.workerPid) : std::nullopt)
        .bind(2, claimer.host.empty() ? std::optional<std::string>() : std::optional(claimer.host))
        .bind(3, claimer.leaseMs)
        .bind(4, *chosen);
    auto job = returnedJob(claim);
    if (!claimer.host.empty()) {
      Statement host(db_, "UPDATE hosts SET current_job = ?1 WHERE name = ?2");
      host.bind(1, *chosen).bind(2, claimer.host).run();
    }
    tx.commit();
    return job;
  });
}

namespace {

// The job row, locked until the transaction ends, if `lease` still holds it.
bool holds(Connection* db, const Lease& lease) {
  Statement query(db, std::string("SELECT 1 FROM jobs WHERE id = ?1 AND status = " + kRunning +
                                  " AND attempts = ?2 "
                                  "AND host = ?3") +
                          (db->engine() == Engine::Postgres ? " FOR UPDATE" : ""));
  query.bind(1, lease.jobId).bind(2, lease.attempt).bind(3, lease.host);
  bool held = query.step();
  query.run();
  return held;
}

}  // namespace

namespace detail {

std::string lostLease(Connection* db, const Lease& lease) {
  auto job = findJob(db, lease.jobId);
  std::string now = !job ? "gone"
                         : std::string(toString(job->status)) + ", attempt " + std::to_string(job->attempts) +
                               (job->host ? " on " + *job->host : "");
  return "job " + std::to_string(lease.jobId) + " attempt " + std::to_string(lease.attempt) +
         " is no longer held by " + lease.host + " (now " + now + ")";
}

bool holdsLease(Connection* db, const Lease& lease) { return holds(db, lease); }

}  // namespace detail

Result<bool> JobQueue::renewLease(const Lease& lease, int64_t leaseMs) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("renewLease", [&]() -> Result<bool> {
    Statement renew(db_, std::string("UPDATE jobs SET lease_expires_ms = ") + nowMsSql(*db_) +
                             " + ?1 WHERE id = ?2 AND status = " + kRunning +
                             " AND attempts = ?3 AND host = ?4");
    renew.bind(1, leaseMs).bind(2, lease.jobId).bind(3, lease.attempt).bind(4, lease.host).run();
    return db_->changes() > 0;
  });
}

Result<Recovery> JobQueue::requeueExpired() {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<Recovery>("requeueExpired", [&]() -> Result<Recovery> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement expired(db_, std::string("SELECT id, attempts, max_attempts, host, attempt_errors, ") +
                               nowMsSql(*db_) + " - lease_expires_ms FROM jobs WHERE status = " + kRunning +
                               " AND "
                               "lease_expires_ms < " +
                               nowMsSql(*db_) + " ORDER BY id" + skipLockedSql(*db_));
    struct Expired {
      int64_t id, attempts, maxAttempts;
      std::string host;
      json errors;
      int64_t agoMs;
    };
    std::vector<Expired> found;
    while (expired.step()) {
      RowReader row(expired);  // a braced list reads its columns in order
      found.push_back({row.getInt(), row.getInt(), row.getInt(), row.getOptText().value_or("an unnamed host"),
                       row.getJson(), row.getInt()});
      row.end();
    }
    Statement requeue(db_,
                      "UPDATE jobs SET status = " + kQueued +
                          ", worker_pid = NULL, lease_expires_ms = NULL, "
                          "progress_done = 0, progress_current = NULL, attempt_errors = ?2 WHERE id = ?1");
    Statement fail(db_, std::string("UPDATE jobs SET status = " + kFailed +
                                    ", worker_pid = NULL, lease_expires_ms = "
                                    "NULL, attempt_errors = ?2, error = ?3, finished_at = ") +
                            nowSql(*db_) + " WHERE id = ?1");
    Statement freeHost(db_, "UPDATE hosts SET current_job = NULL WHERE name = ?1 AND current_job = ?2");
    Recovery recovery;
    for (auto& job : found) {
      if (!job.errors.is_array()) job.errors = json::array();
      job.errors.push_back("attempt " + std::to_string(job.attempts) + " on " + job.host +
                           ": lease expired (not renewed for " + std::to_string(job.agoMs / 1000) +
                           " s past its end; the host died or lost the database)");
      if (job.attempts < job.maxAttempts) {
        requeue.reset();
        requeue.bind(1, job.id).bind(2, job.errors).run();
        recovery.requeued.push_back(job.id);
      } else {
        std::string reasons;
        for (const auto& e : job.errors) reasons += (reasons.empty() ? "" : "; ") + e.get<std::string>();
        fail.reset();
        fail.bind(1, job.id)
            .bind(2, job.errors)
            .bind(3, "failed after " + std::to_string(job.attempts) + " attempts: " + reasons)
            .run();
        recovery.failed.push_back(job.id);
      }
      freeHost.reset();
      freeHost.bind(1, job.host).bind(2, job.id).run();
    }
    if (recovery.requeued.empty()) {
      tx.commit();
    } else {
      commitAnnouncing(tx, db_, location_);
    }
    return recovery;
  });
}

Result<bool> JobQueue::updateProgress(int64_t jobId, int64_t done, int64_t total,
                                      std::optional<std::string> current) {
  if (done < 0 || total < 0) return makeError("progress: done and total must not be negative");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("updateProgress", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(db_,
                     "UPDATE jobs SET progress_done = ?1, progress_total = ?2, progress_current = ?3 "
                     "WHERE id = ?4 AND status = " +
                         kRunning);
    update.bind(1, done).bind(2, total).bind(3, current).bind(4, jobId);
    update.run();
    bool running = db_->changes() > 0;
    tx.commit();
    return running;
  });
}

namespace {

// finish()'s status must end a job: done (its error dropped) or failed.
std::optional<std::string> finishableStatus(JobStatus status, std::optional<std::string>& error) {
  if (status != JobStatus::Done && status != JobStatus::Failed) {
    return std::string("finishJob: status must be done or failed, got ") + toString(status);
  }
  if (status == JobStatus::Done) error.reset();
  return std::nullopt;
}

}  // namespace

Result<bool> JobQueue::finish(int64_t jobId, JobStatus status, std::optional<std::string> error) {
  if (auto bad = finishableStatus(status, error)) return makeError(*bad);
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("finishJob", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(db_, std::string("UPDATE jobs SET status = ?1, error = ?2, finished_at = ") +
                              nowSql(*db_) + " WHERE id = ?3 AND status = " + kRunning);
    update.bind(1, toString(status)).bind(2, error).bind(3, jobId);
    update.run();
    bool changed = db_->changes() > 0;
    tx.commit();
    return changed;
  });
}

Result<bool> JobQueue::finish(const Lease& lease, JobStatus status, std::optional<std::string> error) {
  if (auto bad = finishableStatus(status, error)) return makeError(*bad);
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("finishJob", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    if (!holds(db_, lease)) return false;
    detail::finishHeld(db_, lease, status, error);
    tx.commit();
    return true;
  });
}

namespace detail {

void finishHeld(Connection* db, const Lease& lease, JobStatus status, const std::optional<std::string>& error) {
  Statement update(db, std::string("UPDATE jobs SET status = ?1, error = ?2, lease_expires_ms = NULL, "
                                   "finished_at = ") +
                           nowSql(*db) + " WHERE id = ?3");
  update.bind(1, toString(status)).bind(2, error).bind(3, lease.jobId).run();
  Statement host(db, status == JobStatus::Done
                         ? "UPDATE hosts SET jobs_done = jobs_done + 1, current_job = NULL WHERE name = ?1"
                         : "UPDATE hosts SET jobs_failed = jobs_failed + 1, current_job = NULL WHERE name = ?1");
  host.bind(1, lease.host).run();
}

}  // namespace detail

Result<bool> JobQueue::requeue(const Lease& lease, const std::string& reason) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("requeueJob", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    if (!holds(db_, lease)) return false;
    auto job = findJob(db_, lease.jobId);
    json errors = job && job->attemptErrors.is_array() ? job->attemptErrors : json::array();
    errors.push_back("attempt " + std::to_string(lease.attempt) + " on " + lease.host + ": " + reason);
    Statement requeue(
        db_, "UPDATE jobs SET status = " + kQueued +
                 ", attempts = attempts - 1, worker_pid = NULL, "
                 "lease_expires_ms = NULL, progress_done = 0, progress_current = NULL, attempt_errors = ?2 "
                 "WHERE id = ?1");
    requeue.bind(1, lease.jobId).bind(2, errors).run();
    Statement host(db_, "UPDATE hosts SET current_job = NULL WHERE name = ?1 AND current_job = ?2");
    host.bind(1, lease.host).bind(2, lease.jobId).run();
    commitAnnouncing(tx, db_, location_);
    return true;
  });
}

Result<std::optional<Job>> JobQueue::cancel(int64_t jobId) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<Job>>("cancelJob", [&]() -> Result<std::optional<Job>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(db_, std::string("UPDATE jobs SET status = " + kCancelled + ", finished_at = ") +
                              nowSql(*db_) + " WHERE id = ?1 AND status IN (" + kQueued + ", " + kRunning +
                              ")");
    update.bind(1, jobId);
    update.run();
    auto job = findJob(db_, jobId);
    tx.commit();
    return job;
  });
}

Result<std::optional<Job>> JobQueue::get(int64_t jobId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Job>>("getJob",
                                     [&]() -> Result<std::optional<Job>> { return findJob(db_, jobId); });
}

Result<JobPage> JobQueue::list(std::optional<JobStatus> status, const Page& page) {
  auto after = detail::checkPage(page);
  if (!after) return makeError(after.error());
  std::lock_guard lock(mutex_);
  return guarded<JobPage>("listJobs", [&]() -> Result<JobPage> {
    Statement query(db_, std::string("SELECT ") + kJobColumns +
                             " FROM jobs WHERE (CAST(?1 AS TEXT) IS NULL OR status = ?1) AND (CAST(?2 AS BIGINT) IS NULL OR id < ?2) "
                             "ORDER BY id DESC LIMIT ?3");
    query.bind(1, status ? std::optional<std::string>(toString(*status)) : std::nullopt)
        .bind(2, *after)
        .bind(3, page.limit + 1);  // one more tells whether another page follows
    JobPage out;
    while (query.step()) {
      if (static_cast<int>(out.jobs.size()) == page.limit) {
        out.nextCursor = encodeCursor(out.jobs.back().id);
        break;
      }
      out.jobs.push_back(detail::readJob(query));
    }
    return out;
  });
}

Result<std::map<std::string, int64_t>> JobQueue::counts() {
  std::lock_guard lock(mutex_);
  return guarded<std::map<std::string, int64_t>>("jobCounts", [&]() -> Result<std::map<std::string, int64_t>> {
    std::map<std::string, int64_t> out;
    for (JobStatus s : kJobStatuses) out[toString(s)] = 0;
    Statement query(db_, "SELECT status, count(*) FROM jobs GROUP BY status");
    while (query.step()) {
      RowReader row(query);
      std::string status = row.getText();
      out[status] = row.getInt();
      row.end();
    }
    return out;
  });
}

Result<Recovery> JobQueue::requeueInterrupted(int maxAttempts, std::optional<std::string> host) {
  if (maxAttempts < 1) return makeError("maxAttempts: must be at least 1");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<Recovery>("requeueInterrupted", [&]() -> Result<Recovery> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement running(db_, "SELECT id, attempts FROM jobs WHERE status = " + kRunning +
                               " AND "
                               "(CAST(?1 AS TEXT) IS NULL OR host = ?1 OR host IS NULL) ORDER BY id");
    running.bind(1, host);
    Statement requeue(db_, "UPDATE jobs SET status = " + kQueued +
                               ", worker_pid = NULL, progress_done = 0, "
                               "progress_current = NULL, lease_expires_ms = NULL WHERE id = ?1");
    Statement fail(db_, std::string("UPDATE jobs SET status = " + kFailed +
                                    ", worker_pid = NULL, error = ?2, finished_at = ") +
                            nowSql(*db_) + " WHERE id = ?1");
    std::vector<std::pair<int64_t, int64_t>> interrupted;
    while (running.step()) {
      RowReader row(running);
      int64_t id = row.getInt();
      interrupted.emplace_back(id, row.getInt());
      row.end();
    }
    Recovery recovery;
    for (auto [id, attempts] : interrupted) {
      if (attempts < maxAttempts) {
        requeue.reset();
        requeue.bind(1, id).run();
        recovery.requeued.push_back(id);
      } else {
        fail.reset();
        fail.bind(1, id).bind(2, "interrupted " + std::to_string(attempts) + " times").run();
        recovery.failed.push_back(id);
      }
    }
    if (recovery.requeued.empty()) {
      tx.commit();
    } else {
      commitAnnouncing(tx, db_, location_);
    }
    return recovery;
  });
}

}  // namespace tally::store
