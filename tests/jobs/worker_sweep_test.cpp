// The worker on sweep jobs, with a stand-in for `tallyd capture` (a shell
// script that writes a prepared result to --out): a sweep spec's result is
// stored as one sweep and the job is done; a malformed result, or one of
// another sweep, fails the job with the reason and stores nothing.
#include <sys/stat.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "../store/store_fixture.hpp"
#include "jobs/worker.hpp"

namespace tally::store::testing {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class WorkerSweeps : public StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    dir_ = fs::temp_directory_path() / ("tally-worker-sweep-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "tmp");
  }
  void TearDown() override {
    fs::remove_all(dir_);
    StoreTest::TearDown();
  }

  // Runs one sweep job whose child writes `result`; returns the job as it ended.
  Job run(const json& result) {
    std::ofstream(dir_ / "result.json") << result.dump();
    fs::path script = dir_ / "fake-tallyd.sh";
    {
      // Called as: capture --spec SPEC --out OUT
      std::ofstream out(script);
      out << "#!/bin/sh\ncp '" << (dir_ / "result.json").string() << "' \"$5\"\n";
    }
    ::chmod(script.c_str(), 0755);
    auto created = store_->jobs().create({{"sweep", "depth-reconstruction"}, {"near", {0.01}}});
    EXPECT_TRUE(created) << created.error();
    jobs::WorkerOptions options;
    options.tallydPath = script.string();
    options.tempRoot = dir_ / "tmp";
    options.idlePoll = 20ms;
    options.log = [](const tally::log::Event&) {};
    jobs::Worker worker(*store_, options);
    worker.start();
    Job job;
    auto deadline = std::chrono::steady_clock::now() + 20s;
    while (std::chrono::steady_clock::now() < deadline) {
      auto got = store_->jobs().get(created->job.id);
      if (got && got->has_value() && ((*got)->status == JobStatus::Done || (*got)->status == JobStatus::Failed)) {
        job = **got;
        break;
      }
      std::this_thread::sleep_for(20ms);
    }
    worker.stop();
    return job;
  }

  fs::path dir_;
};

TEST_F(WorkerSweeps, StoresTheSweepAndFinishes) {
  Job job = run(sweepResult());
  ASSERT_EQ(job.status, JobStatus::Done) << job.error.value_or("");
  auto ids = store_->runs().jobSweepIds(job.id);
  ASSERT_TRUE(ids);
  ASSERT_EQ(ids->size(), 1u);
  EXPECT_EQ((*store_->runs().sweep(ids->front()))->result, sweepResult());
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 0);  // a sweep stores no runs
}

TEST_F(WorkerSweeps, MalformedResultFailsTheJobAndStoresNothing) {
  json result = sweepResult();
  result["points"][1]["error"].erase("max_relative");
  Job job = run(result);
  ASSERT_EQ(job.status, JobStatus::Failed);
  ASSERT_TRUE(job.error);
  EXPECT_NE(job.error->find("cannot store the sweep"), std::string::npos) << *job.error;
  EXPECT_NE(job.error->find("points[1].error.max_relative: missing"), std::string::npos) << *job.error;
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM sweeps"), 0);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM devices"), 0);
}

TEST_F(WorkerSweeps, ResultOfAnotherSweepFailsTheJob) {
  json result = sweepResult();
  result["sweep"] = "id-capacity";
  Job job = run(result);
  ASSERT_EQ(job.status, JobStatus::Failed);
  ASSERT_TRUE(job.error);
  EXPECT_NE(job.error->find("names sweep \"id-capacity\", the spec \"depth-reconstruction\""), std::string::npos)
      << *job.error;
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM sweeps"), 0);
}

}  // namespace
}  // namespace tally::store::testing
