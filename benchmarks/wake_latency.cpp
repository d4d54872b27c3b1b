// tally_bench_wake: how soon an idle worker claims a posted job
// (docs/benchmarks.md, "Wake-up"). For each worker count W, W threads each
// open their own Store and JobWaiter (store/job_waiter.hpp) and loop as
// jobs::Worker does: arm, claim, and when nothing is queued wait for an
// announcement (the fallback poll set to a minute). One poster, on its own
// connection (an API daemon's), posts --posts jobs one at a time, each after
// the previous one was claimed and a pause (10 to 30 ms, so that every
// worker is idle again), and times from just before JobQueue::create to the
// claim's return in a worker. The claimed job is finished at once. It prints
// the latencies and how the workers' waits ended; it asserts no figure, and
// exits 1 when a store call fails or a job is not claimed within a minute.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

#include "store/job_waiter.hpp"
#include "store/store.hpp"

namespace tally::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Wake = store::JobWaiter::Wake;

struct Options {
  std::string store;
  std::vector<int> workers = {1, 10};
  int posts = 200;
};

// What the workers share with the poster.
struct Board {
  std::mutex mutex;
  std::condition_variable claimed;
  std::map<int64_t, Clock::time_point> claimedAt;  // job id -> when a worker's claim returned
  std::map<Wake, int64_t> wakes;
  std::string error;
  std::atomic<bool> stopping{false};
};

void workerLoop(const std::string& location, int index, Board& board) {
  auto fail = [&](const std::string& why) {
    std::lock_guard lock(board.mutex);
    if (board.error.empty()) board.error = "worker " + std::to_string(index) + ": " + why;
    board.claimed.notify_all();
  };
  auto store = store::Store::open(location);
  if (!store) return fail(store.error());
  auto waiter = store::JobWaiter::open(location);
  if (!waiter) return fail(waiter.error());
  store::Claimer claimer;
  claimer.workerPid = getpid();
  claimer.host = "bench-wake-" + std::to_string(index);
  claimer.leaseMs = 60000;
  while (!board.stopping) {
    (*waiter)->arm();
    auto job = (*store)->jobs().claim(claimer);
    if (!job) return fail(job.error());
    if (job->has_value()) {
      auto at = Clock::now();
      {
        std::lock_guard lock(board.mutex);
        board.claimedAt[(*job)->id] = at;
      }
      board.claimed.notify_all();
      auto finished = (*store)->jobs().finish(store::Lease{(*job)->id, (*job)->attempts, claimer.host},
                                              store::JobStatus::Done);
      if (!finished) return fail(finished.error());
      continue;
    }
    Wake why = (*waiter)->wait(std::chrono::minutes(1));
    std::lock_guard lock(board.mutex);
    ++board.wakes[why];
  }
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  size_t at = static_cast<size_t>(p * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(at, values.size() - 1)];
}

// One round: W idle workers, `posts` jobs; false when it failed (the reason printed).
bool round(const Options& options, const std::string& location, store::Store& poster, int workers) {
  Board board;
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) threads.emplace_back(workerLoop, location, w, std::ref(board));
  std::mt19937 random(42);
  std::uniform_int_distribution<int> pause(10, 30);
  std::vector<double> latencies;
  std::string error;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the workers connect and go idle
  for (int i = 0; i < options.posts && error.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(pause(random)));
    auto postedAt = Clock::now();
    auto created = poster.jobs().create({{"renderers", {"forward"}}, {"wake", i}});
    if (!created) {
      error = created.error();
      break;
    }
    std::unique_lock lock(board.mutex);
    int64_t id = created->job.id;
    if (!board.claimed.wait_for(lock, std::chrono::minutes(1),
                                [&] { return board.claimedAt.count(id) || !board.error.empty(); })) {
      error = "job " + std::to_string(id) + " not claimed within a minute";
    } else if (!board.error.empty()) {
      error = board.error;
    } else {
      latencies.push_back(std::chrono::duration<double, std::milli>(board.claimedAt[id] - postedAt).count());
    }
  }
  board.stopping = true;
  // Every worker is waiting: a post per worker ends the waits (finished at once, not timed).
  for (int w = 0; w < workers; ++w) (void)poster.jobs().create({{"renderers", {"forward"}}, {"stop", w}});
  for (auto& t : threads) t.join();
  if (!error.empty()) {
    std::fprintf(stderr, "tally_bench_wake: %d worker(s): %s\n", workers, error.c_str());
    return false;
  }
  std::printf("%7d %6zu %8.2f %8.2f %8.2f %8.2f %8lld %9lld %9lld\n", workers, latencies.size(),
              percentile(latencies, 0.5), percentile(latencies, 0.9), percentile(latencies, 0.99),
              *std::max_element(latencies.begin(), latencies.end()),
              static_cast<long long>(std::count_if(latencies.begin(), latencies.end(), [](double ms) { return ms > 50; })),
              static_cast<long long>(board.wakes[Wake::kPosted]), static_cast<long long>(board.wakes[Wake::kTimeout]));
  return true;
}

int run(const Options& options) {
  const bool temporary = options.store.empty();
  const std::string location =
      temporary ? (fs::temp_directory_path() / ("tally_bench_wake_" + std::to_string(getpid()) + ".db")).string()
                : options.store;
  auto removeFiles = [&] {
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(location + suffix);
  };
  if (temporary) removeFiles();
  auto poster = store::Store::open(location);
  if (!poster) {
    std::fprintf(stderr, "tally_bench_wake: %s\n", poster.error().c_str());
    return 1;
  }
  std::printf("Tally wake-up: a job posted to idle workers, from before JobQueue::create to a worker's claim\n");
  std::printf("store: %s (%s)\n", store::isPostgresUrl(location) ? store::redactUrl(location).c_str() : location.c_str(),
              (*poster)->engine() == store::Engine::Postgres ? "PostgreSQL, LISTEN/NOTIFY"
                                                             : "SQLite, in-process announcement");
  std::printf("%7s %6s %8s %8s %8s %8s %8s %9s %9s\n", "workers", "posts", "p50 ms", "p90 ms", "p99 ms", "max ms",
              "> 50 ms", "woken", "polled");
  bool ok = true;
  for (int workers : options.workers) ok = round(options, location, **poster, workers) && ok;
  std::printf("(woken: waits ended by a post's announcement; polled: by the fallback's timeout, 1 minute here)\n");
  poster->reset();
  if (temporary) removeFiles();
  return ok ? 0 : 1;
}

}  // namespace
}  // namespace tally::bench

int main(int argc, char** argv) {
  tally::bench::Options options;
  std::string workers = "1,10";
  CLI::App app{"tally_bench_wake: how soon an idle worker claims a posted job"};
  app.add_option("--store", options.store,
                 "SQLite file or postgresql:// URL (default: a temporary SQLite file, removed afterwards)");
  app.add_option("--workers", workers, "Worker counts, one round each (comma-separated)")->capture_default_str();
  app.add_option("--posts", options.posts, "Jobs posted per round, one at a time")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  options.workers.clear();
  std::stringstream list(workers);
  for (std::string item; std::getline(list, item, ',');) {
    int n = std::atoi(item.c_str());
    if (n < 1 || n > 100) {
      std::fprintf(stderr, "tally_bench_wake: --workers: '%s' is not a count from 1 to 100\n", item.c_str());
      return 2;
    }
    options.workers.push_back(n);
  }
  return tally::bench::run(options);
}
