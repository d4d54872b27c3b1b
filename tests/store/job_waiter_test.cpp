// JobWaiter: a job posted through another Store on the same database ends a
// wait as kPosted (PostgreSQL: NOTIFY heard by the waiter's LISTEN; SQLite:
// the in-process announcement), not by the wait's timeout. The waits are
// long (a minute) so that only the announcement can end them in time; the
// assertions are on why a wait ended, never on how long it took.
#include <future>
#include <thread>

#include "store/job_waiter.hpp"
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

using namespace std::chrono_literals;
using Wake = JobWaiter::Wake;

class JobWaiters : public StoreTest {
 protected:
  std::unique_ptr<JobWaiter> openWaiter() {
    auto waiter = JobWaiter::open(store_->location());
    if (!waiter) ADD_FAILURE() << waiter.error();
    return waiter ? std::move(*waiter) : nullptr;
  }
};

TEST_F(JobWaiters, PostedJobEndsTheWait) {
  auto waiter = openWaiter();
  ASSERT_NE(waiter, nullptr);
  EXPECT_EQ(waiter->hearsOtherProcesses(), db_.postgres());
  auto poster = openStore(db_.path());  // another connection, as an API daemon's
  ASSERT_NE(poster, nullptr);
  waiter->arm();
  auto waited = std::async(std::launch::async, [&] { return waiter->wait(60s); });
  std::this_thread::sleep_for(50ms);  // most likely waiting by now; posting earlier must work too
  auto created = poster->jobs().create({{"renderers", {"forward"}}});
  ASSERT_TRUE(created) << created.error();
  EXPECT_EQ(waited.get(), Wake::kPosted);
}

TEST_F(JobWaiters, PostBetweenArmAndWaitIsNotLost) {
  auto waiter = openWaiter();
  ASSERT_NE(waiter, nullptr);
  waiter->arm();
  ASSERT_TRUE(store_->jobs().create({{"renderers", {"forward"}}}));
  EXPECT_EQ(waiter->wait(60s), Wake::kPosted);
}

// A post before arm() is the worker's look at the queue to find, not a
// reason to wake. In-process (SQLite) it never wakes the wait; a NOTIFY
// reaches the listener's socket a little after the commit returns, so on
// PostgreSQL it may wake the first wait (a harmless extra look), never a later one.
TEST_F(JobWaiters, ArmForgetsEarlierPosts) {
  auto waiter = openWaiter();
  ASSERT_NE(waiter, nullptr);
  ASSERT_TRUE(store_->jobs().create({{"renderers", {"forward"}}}));
  waiter->arm();
  Wake first = waiter->wait(db_.postgres() ? 1000ms : 100ms);
  if (!db_.postgres()) {
    EXPECT_EQ(first, Wake::kTimeout);
  }
  waiter->arm();
  EXPECT_EQ(waiter->wait(100ms), Wake::kTimeout);
}

TEST_F(JobWaiters, InterruptEndsTheWait) {
  auto waiter = openWaiter();
  ASSERT_NE(waiter, nullptr);
  waiter->arm();
  auto waited = std::async(std::launch::async, [&] { return waiter->wait(60s); });
  waiter->interrupt();
  EXPECT_EQ(waited.get(), Wake::kInterrupted);
  // Consumed: the next wait is not interrupted.
  waiter->arm();
  EXPECT_EQ(waiter->wait(10ms), Wake::kTimeout);
}

// A job queued again (its host stopped it) is claimable: announced like a new one.
TEST_F(JobWaiters, RequeuedJobIsAnnounced) {
  auto created = store_->jobs().create({{"renderers", {"forward"}}});
  ASSERT_TRUE(created) << created.error();
  Claimer claimer;
  claimer.host = "host-a";
  auto claimed = store_->jobs().claim(claimer);
  ASSERT_TRUE(claimed && claimed->has_value());
  auto waiter = openWaiter();
  ASSERT_NE(waiter, nullptr);
  waiter->arm();
  auto requeued = store_->jobs().requeue(Lease{created->job.id, 1, "host-a"}, "the daemon stopped");
  ASSERT_TRUE(requeued && *requeued);
  EXPECT_EQ(waiter->wait(60s), Wake::kPosted);
}

// Nothing is announced for a job that was not created: a repeated
// idempotency key returns the existing job.
TEST_F(JobWaiters, RepeatedIdempotencyKeyAnnouncesNothing) {
  ASSERT_TRUE(store_->jobs().create({{"renderers", {"forward"}}}, "key-1"));
  auto waiter = openWaiter();
  ASSERT_NE(waiter, nullptr);
  waiter->arm();
  auto again = store_->jobs().create({{"renderers", {"forward"}}}, "key-1");
  ASSERT_TRUE(again && !again->created);
  EXPECT_EQ(waiter->wait(200ms), Wake::kTimeout);
}

}  // namespace
}  // namespace tally::store::testing
