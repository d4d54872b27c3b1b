// The job queue: idempotency keys, claim/progress/finish/cancel, recovery.
#include <set>
#include <thread>

#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

using Jobs = StoreTest;

const json kSpec = {{"renderers", {"forward", "deferred"}}, {"resolutions", {{320, 180}}}};

TEST_F(Jobs, CreateWithIdempotencyKey) {
  auto first = store_->jobs().create(kSpec, "abc");
  ASSERT_TRUE(first) << first.error();
  EXPECT_TRUE(first->created);
  EXPECT_FALSE(first->conflict);
  EXPECT_EQ(first->job.status, JobStatus::Queued);
  EXPECT_EQ(first->job.spec, kSpec);
  EXPECT_EQ(first->job.attempts, 0);
  EXPECT_EQ(first->job.idempotencyKey, "abc");
  EXPECT_FALSE(first->job.createdAt.empty());
  EXPECT_FALSE(first->job.startedAt);

  auto again = store_->jobs().create(kSpec, "abc");
  ASSERT_TRUE(again);
  EXPECT_FALSE(again->created);
  EXPECT_FALSE(again->conflict);
  EXPECT_EQ(again->job.id, first->job.id);

  auto other = store_->jobs().create({{"renderers", {"visbuffer"}}}, "abc");
  ASSERT_TRUE(other);
  EXPECT_FALSE(other->created);
  EXPECT_TRUE(other->conflict);
  EXPECT_EQ(other->job.id, first->job.id);
  EXPECT_EQ(other->job.spec, kSpec);

  auto noKey1 = store_->jobs().create(kSpec);
  auto noKey2 = store_->jobs().create(kSpec);
  ASSERT_TRUE(noKey1 && noKey2);
  EXPECT_NE(noKey1->job.id, noKey2->job.id);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM jobs"), 3);

  EXPECT_FALSE(store_->jobs().create(kSpec, ""));
  EXPECT_FALSE(store_->jobs().create(kSpec, std::string(256, 'k')));
}

TEST_F(Jobs, Lifecycle) {
  int64_t a = newJob(), b = newJob();
  auto claimed = store_->jobs().claim(4242);
  ASSERT_TRUE(claimed && claimed->has_value());
  EXPECT_EQ((*claimed)->id, a);  // oldest first
  EXPECT_EQ((*claimed)->status, JobStatus::Running);
  EXPECT_EQ((*claimed)->attempts, 1);
  EXPECT_EQ((*claimed)->workerPid, 4242);
  EXPECT_TRUE((*claimed)->startedAt);

  auto progress = store_->jobs().updateProgress(a, 3, 10, "forward atrium 320x180 camera 3");
  ASSERT_TRUE(progress && *progress);
  auto job = store_->jobs().get(a);
  ASSERT_TRUE(job && job->has_value());
  EXPECT_EQ((*job)->progressDone, 3);
  EXPECT_EQ((*job)->progressTotal, 10);
  EXPECT_EQ((*job)->progressCurrent, "forward atrium 320x180 camera 3");
  EXPECT_FALSE(store_->jobs().updateProgress(a, -1, 10));

  auto finished = store_->jobs().finish(a, JobStatus::Done);
  ASSERT_TRUE(finished && *finished);
  job = store_->jobs().get(a);
  EXPECT_EQ((*job)->status, JobStatus::Done);
  EXPECT_TRUE((*job)->finishedAt);
  EXPECT_FALSE((*job)->error);
  EXPECT_FALSE(*store_->jobs().updateProgress(a, 4, 10));      // no longer running
  EXPECT_FALSE(*store_->jobs().finish(a, JobStatus::Failed));  // stays done
  EXPECT_FALSE(store_->jobs().finish(a, JobStatus::Queued));   // not a finishing status

  claimed = store_->jobs().claim();
  ASSERT_TRUE(claimed && claimed->has_value());
  EXPECT_EQ((*claimed)->id, b);
  EXPECT_FALSE((*claimed)->workerPid);
  ASSERT_TRUE(*store_->jobs().finish(b, JobStatus::Failed, "device lost"));
  job = store_->jobs().get(b);
  EXPECT_EQ((*job)->status, JobStatus::Failed);
  EXPECT_EQ((*job)->error, "device lost");

  claimed = store_->jobs().claim();
  ASSERT_TRUE(claimed);
  EXPECT_FALSE(claimed->has_value());  // queue empty

  auto missing = store_->jobs().get(12345);
  ASSERT_TRUE(missing);
  EXPECT_FALSE(missing->has_value());
}

TEST_F(Jobs, Cancel) {
  int64_t running = newJob(), queued = newJob(), done = newJob();
  ASSERT_EQ((**store_->jobs().claim()).id, running);

  auto q = store_->jobs().cancel(queued);
  ASSERT_TRUE(q && q->has_value());
  EXPECT_EQ((*q)->status, JobStatus::Cancelled);
  EXPECT_TRUE((*q)->finishedAt);

  auto r = store_->jobs().cancel(running);
  ASSERT_TRUE(r && r->has_value());
  EXPECT_EQ((*r)->status, JobStatus::Cancelled);
  EXPECT_FALSE(*store_->jobs().updateProgress(running, 1, 2));     // the worker learns it was cancelled
  EXPECT_FALSE(*store_->jobs().finish(running, JobStatus::Done));  // and cannot undo it
  EXPECT_EQ((*store_->jobs().get(running))->status, JobStatus::Cancelled);

  ASSERT_EQ((**store_->jobs().claim()).id, done);  // cancelled jobs are never claimed
  ASSERT_TRUE(*store_->jobs().finish(done, JobStatus::Done));
  auto d = store_->jobs().cancel(done);
  ASSERT_TRUE(d && d->has_value());
  EXPECT_EQ((*d)->status, JobStatus::Done);  // finished jobs stay as they are

  auto none = store_->jobs().cancel(999);
  ASSERT_TRUE(none);
  EXPECT_FALSE(none->has_value());
}

TEST_F(Jobs, ListByStatusNewestFirst) {
  std::vector<int64_t> ids;
  for (int i = 0; i < 5; ++i) ids.push_back(newJob());
  ASSERT_TRUE(store_->jobs().claim());  // ids[0] running
  auto all = store_->jobs().list({}, {});
  ASSERT_TRUE(all) << all.error();
  ASSERT_EQ(all->jobs.size(), 5u);
  EXPECT_EQ(all->jobs.front().id, ids[4]);
  EXPECT_TRUE(all->nextCursor.empty());
  auto queued = store_->jobs().list(JobStatus::Queued, {});
  ASSERT_TRUE(queued);
  EXPECT_EQ(queued->jobs.size(), 4u);
  auto running = store_->jobs().list(JobStatus::Running, {});
  ASSERT_TRUE(running && running->jobs.size() == 1);
  EXPECT_EQ(running->jobs.front().id, ids[0]);
  // Pages of 2: ids 4 3 | 2 1 | 0.
  std::vector<int64_t> seen;
  Page page{.limit = 2};
  for (int pages = 0; pages < 10; ++pages) {
    auto got = store_->jobs().list({}, page);
    ASSERT_TRUE(got) << got.error();
    for (const auto& job : got->jobs) seen.push_back(job.id);
    if (got->nextCursor.empty()) break;
    page.cursor = got->nextCursor;
  }
  EXPECT_EQ(seen, (std::vector<int64_t>{ids[4], ids[3], ids[2], ids[1], ids[0]}));
  EXPECT_FALSE(store_->jobs().list({}, {.limit = 0}));
  EXPECT_FALSE(store_->jobs().list({}, {.limit = 1001}));
  EXPECT_FALSE(store_->jobs().list({}, {.limit = 10, .cursor = "bogus"}));
  EXPECT_EQ(parseJobStatus("cancelled"), JobStatus::Cancelled);
  EXPECT_FALSE(parseJobStatus("paused"));
}

TEST_F(Jobs, RequeueInterrupted) {
  // Simulates three daemon crashes: each time every queued job is claimed,
  // then start-up recovery runs with at most 3 attempts.
  int64_t a = newJob(), b = newJob(), late = 0;
  for (int crash = 1; crash <= 3; ++crash) {
    if (crash == 3) late = newJob();
    while (true) {
      auto job = store_->jobs().claim(1000 + crash);
      ASSERT_TRUE(job);
      if (!job->has_value()) break;
    }
    auto recovery = store_->jobs().requeueInterrupted(3);
    ASSERT_TRUE(recovery) << recovery.error();
    if (crash < 3) {
      EXPECT_EQ(recovery->requeued, (std::vector<int64_t>{a, b}));
      EXPECT_TRUE(recovery->failed.empty());
    } else {
      EXPECT_EQ(recovery->requeued, std::vector<int64_t>{late});
      EXPECT_EQ(recovery->failed, (std::vector<int64_t>{a, b}));
    }
  }
  for (int64_t id : {a, b}) {
    auto job = *store_->jobs().get(id);
    EXPECT_EQ(job->status, JobStatus::Failed);
    EXPECT_EQ(job->error, "interrupted 3 times");
    EXPECT_EQ(job->attempts, 3);
    EXPECT_TRUE(job->finishedAt);
    EXPECT_FALSE(job->workerPid);
  }
  auto job = *store_->jobs().get(late);
  EXPECT_EQ(job->status, JobStatus::Queued);
  EXPECT_EQ(job->attempts, 1);
  auto nothing = store_->jobs().requeueInterrupted(3);  // nothing running: a no-op
  ASSERT_TRUE(nothing);
  EXPECT_TRUE(nothing->requeued.empty() && nothing->failed.empty());
}

TEST_F(Jobs, RequeueKeepsJobsUnderTheLimit) {
  int64_t a = newJob(), b = newJob();
  ASSERT_TRUE(store_->jobs().claim(100));
  ASSERT_TRUE(store_->jobs().updateProgress(a, 5, 10));
  auto recovery = store_->jobs().requeueInterrupted(3);
  ASSERT_TRUE(recovery);
  EXPECT_EQ(recovery->requeued, std::vector<int64_t>{a});
  EXPECT_TRUE(recovery->failed.empty());
  auto job = *store_->jobs().get(a);
  EXPECT_EQ(job->status, JobStatus::Queued);
  EXPECT_EQ(job->attempts, 1);
  EXPECT_EQ(job->progressDone, 0);
  EXPECT_FALSE(job->workerPid);
  EXPECT_EQ((*store_->jobs().get(b))->status, JobStatus::Queued);
  // Requeued jobs keep their place: `a` is claimed again before `b`.
  EXPECT_EQ((**store_->jobs().claim()).id, a);
  EXPECT_EQ((*store_->jobs().get(a))->attempts, 2);
  EXPECT_FALSE(store_->jobs().requeueInterrupted(0));
}

TEST_F(Jobs, ConcurrentClaimsTakeEachJobOnce) {
  constexpr int kJobs = 40;
  for (int i = 0; i < kJobs; ++i) newJob();
  std::vector<std::vector<int64_t>> claimed(4);
  std::vector<std::thread> workers;
  for (size_t w = 0; w < claimed.size(); ++w) {
    workers.emplace_back([&, w] {
      auto store = Store::open(db_.path());
      ASSERT_TRUE(store) << store.error();
      while (true) {
        auto job = (*store)->jobs().claim(static_cast<int64_t>(w + 1));
        ASSERT_TRUE(job) << job.error();
        if (!job->has_value()) break;
        claimed[w].push_back((*job)->id);
      }
    });
  }
  for (auto& t : workers) t.join();
  std::set<int64_t> all;
  size_t total = 0;
  for (const auto& ids : claimed) {
    all.insert(ids.begin(), ids.end());
    total += ids.size();
  }
  EXPECT_EQ(total, static_cast<size_t>(kJobs));
  EXPECT_EQ(all.size(), static_cast<size_t>(kJobs));
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM jobs WHERE status = 'running' AND attempts = 1"), kJobs);
}

// The queue's limits are counted in the transaction that inserts: queued
// jobs only, per client where one is named; a repeated key passes.
TEST_F(Jobs, QueueLimitsCountQueuedJobs) {
  QueueLimits limits{"peer:a", 3, 2};
  auto a1 = store_->jobs().create(kSpec, std::nullopt, 3, limits);
  auto a2 = store_->jobs().create(kSpec, "k", 3, limits);
  ASSERT_TRUE(a1 && a2);
  EXPECT_TRUE(a1->created && a2->created);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM jobs WHERE client = 'peer:a'"), 2);
  auto a3 = store_->jobs().create(kSpec, std::nullopt, 3, limits);
  ASSERT_TRUE(a3);
  EXPECT_FALSE(a3->created);
  EXPECT_EQ(a3->refused, "client");
  EXPECT_EQ(a3->queued, 2);
  auto again = store_->jobs().create(kSpec, "k", 3, limits);  // its job, whatever the limits
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->refused.empty());
  EXPECT_EQ(again->job.id, a2->job.id);

  QueueLimits b{"peer:b", 3, 2};
  auto b1 = store_->jobs().create(kSpec, std::nullopt, 3, b);
  ASSERT_TRUE(b1 && b1->created);
  auto b2 = store_->jobs().create(kSpec, std::nullopt, 3, b);
  ASSERT_TRUE(b2);
  EXPECT_EQ(b2->refused, "queue");
  EXPECT_EQ(b2->queued, 3);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM jobs"), 3);

  // A claimed job no longer counts.
  auto claimed = store_->jobs().claim(1);
  ASSERT_TRUE(claimed && claimed->has_value());
  auto b3 = store_->jobs().create(kSpec, std::nullopt, 3, b);
  ASSERT_TRUE(b3);
  EXPECT_TRUE(b3->created) << b3->refused;
}

// A job its host gives up when it stops goes back to the queue with the
// reason, and the claim does not count as an attempt.
TEST_F(Jobs, RequeueJobGivesTheClaimBack) {
  int64_t id = newJob();
  Claimer claimer;
  claimer.host = "a";
  auto claimed = store_->jobs().claim(claimer);
  ASSERT_TRUE(claimed && claimed->has_value());
  Lease lease{id, 1, "a"};
  auto requeued = store_->jobs().requeue(lease, "stopped: shutting down");
  ASSERT_TRUE(requeued) << requeued.error();
  EXPECT_TRUE(*requeued);
  auto job = store_->jobs().get(id);
  ASSERT_TRUE(job && job->has_value());
  EXPECT_EQ((*job)->status, JobStatus::Queued);
  EXPECT_EQ((*job)->attempts, 0);
  ASSERT_EQ((*job)->attemptErrors.size(), 1u);
  EXPECT_EQ((*job)->attemptErrors[0], "attempt 1 on a: stopped: shutting down");
  auto stale = store_->jobs().requeue(lease, "again");  // no longer held
  ASSERT_TRUE(stale);
  EXPECT_FALSE(*stale);
}

}  // namespace
}  // namespace tally::store::testing
