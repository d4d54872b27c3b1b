// An idle worker is woken by a posted job, not by its fallback poll: the
// poll is set to an hour, the job is posted through another Store on the
// same database (as the API daemon posts it), and the worker's wait must end
// as kPosted before the job runs. Run on SQLite (the in-process
// announcement) and, as worker.postgresql, on PostgreSQL (LISTEN/NOTIFY).
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "fake_capture.hpp"
#include "jobs/worker.hpp"

namespace tally::store::testing {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using jobs::WaitEvent;

class WorkerWake : public StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    dir_ = fs::temp_directory_path() / ("tally-worker-wake-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "tmp");
  }
  void TearDown() override {
    fs::remove_all(dir_);
    StoreTest::TearDown();
  }

  // The worker's wait events, as they happen.
  struct Events {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<WaitEvent> seen;
    bool waitFor(WaitEvent event, std::chrono::seconds limit) {
      std::unique_lock lock(mutex);
      return changed.wait_for(lock, limit, [&] { return std::count(seen.begin(), seen.end(), event) > 0; });
    }
  };

  jobs::WorkerOptions options(Events& events) {
    jobs::WorkerOptions o;
    o.tallydPath = writeFakeCapture(dir_).string();
    o.tempRoot = dir_ / "tmp";
    o.idlePoll = 1h;  // the fallback cannot be what finds the job
    o.log = [](const tally::log::Event&) {};
    o.onWait = [&events](WaitEvent event) {
      std::lock_guard lock(events.mutex);
      events.seen.push_back(event);
      events.changed.notify_all();
    };
    return o;
  }

  fs::path dir_;
};

TEST_F(WorkerWake, PostedJobIsClaimedWithoutWaitingForThePoll) {
  Events events;
  jobs::Worker worker(*store_, options(events));
  worker.start();
  // Idle: it found the queue empty and waits.
  ASSERT_TRUE(events.waitFor(WaitEvent::kIdle, 30s));
  auto api = openStore(db_.path());
  ASSERT_NE(api, nullptr);
  auto created = api->jobs().create({{"renderers", {"forward"}}});
  ASSERT_TRUE(created) << created.error();
  // Woken by the post: the wait ended as kPosted (with an hour's poll, nothing else could end it).
  ASSERT_TRUE(events.waitFor(WaitEvent::kPosted, 60s));
  std::optional<Job> job;
  for (int tries = 0; tries < 600 && !(job && job->status == JobStatus::Done); ++tries) {
    auto got = api->jobs().get(created->job.id);
    if (got && got->has_value()) job = **got;
    std::this_thread::sleep_for(50ms);
  }
  worker.stop();
  ASSERT_TRUE(job);
  EXPECT_EQ(job->status, JobStatus::Done) << job->error.value_or("");
  EXPECT_EQ(job->attempts, 1);
  std::lock_guard lock(events.mutex);
  EXPECT_EQ(std::count(events.seen.begin(), events.seen.end(), WaitEvent::kPolled), 0);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs WHERE job_id = " + std::to_string(created->job.id)), 1);
}

// wake() ends an idle wait at once (the daemon's own API posting, and stop()).
TEST_F(WorkerWake, WakeEndsTheWait) {
  Events events;
  jobs::Worker worker(*store_, options(events));
  worker.start();
  ASSERT_TRUE(events.waitFor(WaitEvent::kIdle, 30s));
  worker.wake();
  EXPECT_TRUE(events.waitFor(WaitEvent::kInterrupted, 60s));
  worker.stop();
}

}  // namespace
}  // namespace tally::store::testing
