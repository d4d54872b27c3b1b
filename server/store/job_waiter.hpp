// Waking idle workers when a job is posted, instead of having them poll the
// queue (docs/fleet.md, "Wake-up").
//
// A job becomes claimable when it is created or queued again (a stopped
// host's job, an expired lease, a restart's recovery). The JobQueue then
// announces it:
//   - PostgreSQL: NOTIFY on the channel kJobChannel in the same transaction,
//     so every daemon LISTENing on the database hears it when (and only if)
//     the transaction commits;
//   - SQLite: after the commit, an in-process notification keyed by the
//     database's path, which wakes the waiters of this process. Daemons in
//     other processes on the same file hear nothing: they find the job at
//     their fallback poll.
//
// A waiter is one per worker:
//
//   auto waiter = JobWaiter::open(store.location());
//   for (;;) {
//     waiter->arm();                  // before looking: what was posted
//     if (claim()) continue;          //   until now, the look finds
//     waiter->wait(fallbackPoll);     // a post after arm() ends the wait
//   }
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "common/result.hpp"

namespace tally::store {

// The PostgreSQL channel that job posts are announced on.
inline constexpr const char* kJobChannel = "tally_jobs";

class JobWaiter {
 public:
  enum class Wake {
    kPosted,       // a job was announced after arm()
    kTimeout,      // the fallback: nothing heard within the timeout
    kInterrupted,  // interrupt() was called
  };

  // location: a SQLite path or a postgresql:// URL, as given to Store::open.
  // PostgreSQL: opens a connection of its own and LISTENs on kJobChannel;
  // an error when the server cannot be reached.
  static Result<std::unique_ptr<JobWaiter>> open(const std::string& location);
  virtual ~JobWaiter() = default;

  // Forgets what was announced so far; call it before looking at the queue.
  virtual void arm() = 0;
  // Until a job is announced after the last arm(), interrupt(), or timeout.
  // A PostgreSQL waiter whose connection was lost reconnects at the next
  // arm(); until then it waits at most kRetryAfterLoss.
  virtual Wake wait(std::chrono::milliseconds timeout) = 0;
  // From any thread: the wait in progress, or else the next one, returns kInterrupted.
  virtual void interrupt() = 0;
  // Whether announcements from other processes reach this waiter
  // (PostgreSQL, while its connection listens; never on SQLite).
  virtual bool hearsOtherProcesses() const = 0;

  static constexpr std::chrono::milliseconds kRetryAfterLoss{1000};
};

const char* toString(JobWaiter::Wake wake);

namespace detail {
// The in-process announcement of a SQLite store's job posts (JobQueue calls it after the commit).
void announceJobsInProcess(const std::string& location);
}  // namespace detail

}  // namespace tally::store
