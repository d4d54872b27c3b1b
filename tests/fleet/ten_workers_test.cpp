// Ten workers, one PostgreSQL, 1,000 jobs (fleet.ten_workers). Each worker
// is a jobs::Worker as `tallyd serve --role worker` runs it: its own store
// connection, a host row, a heartbeat, a listener woken by the posts, and a
// mock capture in a child process (a script that writes a small result) that
// is ingested under the job's lease. The workers start idle; the jobs are
// posted afterwards, one transaction each, from another connection (an API
// daemon's). Checked from the store: every job done exactly once (one
// attempt, one run, no error), and the hosts' counts add up. The throughput
// is printed (and recorded as the test's properties), never asserted.
#include <chrono>
#include <cstdio>
#include <thread>

#include "../jobs/fake_capture.hpp"
#include "jobs/worker.hpp"

namespace tally::store::testing {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

constexpr int kWorkers = 10;
constexpr int kJobs = 1000;

TEST(TenWorkers, EveryJobDoneExactlyOnce) {
  auto* server = tally::testing::requirePostgres();
  if (server == nullptr) return;  // skipped, or failed where tests are strict
  const std::string url = server->createDatabase();
  auto api = openStore(url);
  ASSERT_NE(api, nullptr);
  fs::path dir = fs::temp_directory_path() / ("tally-ten-workers-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "tmp");
  fs::path script = writeFakeCapture(dir);

  std::vector<std::unique_ptr<Store>> stores;
  std::vector<std::unique_ptr<jobs::Worker>> workers;
  for (int w = 0; w < kWorkers; ++w) {
    stores.push_back(openStore(url));
    ASSERT_NE(stores.back(), nullptr);
    jobs::WorkerOptions options;
    options.tallydPath = script.string();
    options.tempRoot = dir / "tmp";
    options.log = [](const tally::log::Event&) {};
    options.host.name = "worker-" + std::to_string(w);
    options.host.role = "worker";
    options.openHeartbeatStore = [url] { return Store::open(url); };
    workers.push_back(std::make_unique<jobs::Worker>(*stores.back(), options));
    auto recovered = workers.back()->recover();
    ASSERT_TRUE(recovered) << recovered.error();
  }
  for (auto& worker : workers) worker->start();

  auto started = std::chrono::steady_clock::now();
  for (int j = 0; j < kJobs; ++j) {
    auto created = api->jobs().create({{"renderers", {"forward"}}, {"n", j}});
    ASSERT_TRUE(created) << created.error();
  }
  auto posted = std::chrono::steady_clock::now();
  int64_t done = 0;
  auto deadline = started + 150s;
  while (std::chrono::steady_clock::now() < deadline) {
    auto counts = api->jobs().counts();
    ASSERT_TRUE(counts) << counts.error();
    done = (*counts)["done"] + (*counts)["failed"];
    if (done == kJobs) break;
    std::this_thread::sleep_for(20ms);
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  for (auto& worker : workers) worker->stop();
  fs::remove_all(dir);
  ASSERT_EQ(done, kJobs) << "jobs finished within 150 s";

  double postSeconds = std::chrono::duration<double>(posted - started).count();
  std::printf("fleet.ten_workers: %d jobs by %d workers in %.2f s: %.0f jobs/s (posting took %.2f s)\n", kJobs,
              kWorkers, seconds, kJobs / seconds, postSeconds);
  ::testing::Test::RecordProperty("jobs_per_second", std::to_string(kJobs / seconds));
  ::testing::Test::RecordProperty("seconds", std::to_string(seconds));

  EXPECT_EQ(scalar(*api, "SELECT COUNT(*) FROM jobs"), kJobs);
  EXPECT_EQ(scalar(*api, "SELECT COUNT(*) FROM jobs WHERE status = 'done' AND attempts = 1 AND error IS NULL"), kJobs);
  // Claimed once: no job was ever given back or taken over.
  EXPECT_EQ(scalar(*api, "SELECT COUNT(*) FROM jobs WHERE attempt_errors IS NOT NULL AND attempt_errors <> '[]'"), 0);
  // Stored once: one run per job, every job's.
  EXPECT_EQ(scalar(*api, "SELECT COUNT(*) FROM runs"), kJobs);
  EXPECT_EQ(scalar(*api, "SELECT COUNT(DISTINCT job_id) FROM runs"), kJobs);
  // Each job's run names the host that held it, and the hosts' counts add up.
  EXPECT_EQ(scalar(*api, "SELECT COUNT(*) FROM runs r JOIN jobs j ON j.id = r.job_id WHERE r.host = j.host"), kJobs);
  EXPECT_EQ(scalar(*api, "SELECT SUM(jobs_done) FROM hosts"), kJobs);
  EXPECT_EQ(scalar(*api, "SELECT COUNT(*) FROM hosts WHERE jobs_done > 0"), kWorkers) << "every worker took jobs";
}

}  // namespace
}  // namespace tally::store::testing
