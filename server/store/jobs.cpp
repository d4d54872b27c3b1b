// The persistent job queue: transitions queued -> running -> done | failed,
// and queued | running -> cancelled. Each transition is one write transaction.
#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;
using detail::kJobColumns;
using nlohmann::json;

namespace detail {

Job readJob(const Statement& row) {
  Job job;
  job.id = row.getInt(0);
  job.status = parseJobStatus(row.getText(1)).value_or(JobStatus::Failed);
  job.spec = row.getJson(2);
  job.progressDone = row.getInt(3);
  job.progressTotal = row.getInt(4);
  job.progressCurrent = row.getOptText(5);
  job.error = row.getOptText(6);
  job.attempts = static_cast<int>(row.getInt(7));
  job.idempotencyKey = row.getOptText(8);
  job.createdAt = row.getText(9);
  job.startedAt = row.getOptText(10);
  job.finishedAt = row.getOptText(11);
  job.workerPid = row.getOptInt(12);
  return job;
}

}  // namespace detail

namespace {

std::optional<Job> findJob(Connection* db, int64_t id) {
  Statement query(db, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?1");
  query.bind(1, id);
  if (!query.step()) return std::nullopt;
  return detail::readJob(query);
}

// Reads the single row of an "... RETURNING" statement and finishes it.
std::optional<Job> returnedJob(Statement& statement) {
  std::optional<Job> job;
  if (statement.step()) job = detail::readJob(statement);
  statement.run();
  return job;
}

}  // namespace

Result<CreatedJob> Store::createJob(const json& spec, std::optional<std::string> idempotencyKey) {
  if (idempotencyKey && (idempotencyKey->empty() || idempotencyKey->size() > 255)) {
    return makeError("idempotency_key: must be 1 to 255 characters");
  }
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
    Statement insert(db_, std::string("INSERT INTO jobs (spec, idempotency_key) VALUES (?1, ?2) RETURNING ") +
                              kJobColumns);
    insert.bind(1, spec).bind(2, idempotencyKey);
    out.job = returnedJob(insert).value();
    out.created = true;
    tx.commit();
    return out;
  });
}

Result<std::optional<Job>> Store::claimNextJob(int64_t workerPid) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<Job>>("claimNextJob", [&]() -> Result<std::optional<Job>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement claim(
        db_, std::string("UPDATE jobs SET status = 'running', attempts = attempts + 1, started_at = ") +
                 nowSql(*db_) +
                 ", finished_at = NULL, error = NULL, progress_done = 0, progress_current = NULL, "
                 "worker_pid = ?1 "
                 "WHERE id = (SELECT id FROM jobs WHERE status = 'queued' ORDER BY id LIMIT 1) "
                 "RETURNING " +
                 kJobColumns);
    claim.bind(1, workerPid > 0 ? std::optional<int64_t>(workerPid) : std::nullopt);
    auto job = returnedJob(claim);
    tx.commit();
    return job;
  });
}

Result<bool> Store::updateProgress(int64_t jobId, int64_t done, int64_t total,
                                   std::optional<std::string> current) {
  if (done < 0 || total < 0) return makeError("progress: done and total must not be negative");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("updateProgress", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(db_,
                     "UPDATE jobs SET progress_done = ?1, progress_total = ?2, progress_current = ?3 "
                     "WHERE id = ?4 AND status = 'running'");
    update.bind(1, done).bind(2, total).bind(3, current).bind(4, jobId);
    update.run();
    bool running = db_->changes() > 0;
    tx.commit();
    return running;
  });
}

Result<bool> Store::finishJob(int64_t jobId, JobStatus status, std::optional<std::string> error) {
  if (status != JobStatus::Done && status != JobStatus::Failed) {
    return makeError(std::string("finishJob: status must be done or failed, got ") + toString(status));
  }
  if (status == JobStatus::Done) error.reset();
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("finishJob", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(db_, std::string("UPDATE jobs SET status = ?1, error = ?2, finished_at = ") + nowSql(*db_) +
                              " WHERE id = ?3 AND status = 'running'");
    update.bind(1, toString(status)).bind(2, error).bind(3, jobId);
    update.run();
    bool changed = db_->changes() > 0;
    tx.commit();
    return changed;
  });
}

Result<std::optional<Job>> Store::cancelJob(int64_t jobId) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<std::optional<Job>>("cancelJob", [&]() -> Result<std::optional<Job>> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement update(db_, std::string("UPDATE jobs SET status = 'cancelled', finished_at = ") + nowSql(*db_) +
                              " WHERE id = ?1 AND status IN ('queued', 'running')");
    update.bind(1, jobId);
    update.run();
    auto job = findJob(db_, jobId);
    tx.commit();
    return job;
  });
}

Result<std::optional<Job>> Store::getJob(int64_t jobId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Job>>("getJob",
                                     [&]() -> Result<std::optional<Job>> { return findJob(db_, jobId); });
}

Result<JobPage> Store::listJobs(std::optional<JobStatus> status, const Page& page) {
  auto after = detail::checkPage(page);
  if (!after) return makeError(after.error());
  std::lock_guard lock(mutex_);
  return guarded<JobPage>("listJobs", [&]() -> Result<JobPage> {
    Statement query(db_, std::string("SELECT ") + kJobColumns +
                             " FROM jobs WHERE (?1 IS NULL OR status = ?1) AND (?2 IS NULL OR id < ?2) "
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

Result<std::map<std::string, int64_t>> Store::jobCounts() {
  std::lock_guard lock(mutex_);
  return guarded<std::map<std::string, int64_t>>("jobCounts", [&]() -> Result<std::map<std::string, int64_t>> {
    std::map<std::string, int64_t> out;
    for (auto s : {JobStatus::Queued, JobStatus::Running, JobStatus::Done, JobStatus::Failed, JobStatus::Cancelled})
      out[toString(s)] = 0;
    Statement query(db_, "SELECT status, count(*) FROM jobs GROUP BY status");
    while (query.step()) out[query.getText(0)] = query.getInt(1);
    return out;
  });
}

Result<Recovery> Store::requeueInterrupted(int maxAttempts) {
  if (maxAttempts < 1) return makeError("maxAttempts: must be at least 1");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<Recovery>("requeueInterrupted", [&]() -> Result<Recovery> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement running(db_, "SELECT id, attempts FROM jobs WHERE status = 'running' ORDER BY id");
    Statement requeue(db_,
                      "UPDATE jobs SET status = 'queued', worker_pid = NULL, progress_done = 0, "
                      "progress_current = NULL WHERE id = ?1");
    Statement fail(
        db_, std::string("UPDATE jobs SET status = 'failed', worker_pid = NULL, error = ?2, finished_at = ") +
                 nowSql(*db_) + " WHERE id = ?1");
    std::vector<std::pair<int64_t, int64_t>> interrupted;
    while (running.step()) interrupted.emplace_back(running.getInt(0), running.getInt(1));
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
    tx.commit();
    return recovery;
  });
}

}  // namespace tally::store
