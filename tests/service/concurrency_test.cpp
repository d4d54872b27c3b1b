// 50 clients read from a real `tallyd serve` while a capture runs and is
// ingested: every read succeeds (no timeouts, no SQLITE_BUSY leaking out as a
// 500), and every read is a consistent snapshot: a listed run always has all
// of its samples, and the running capture's runs appear all at once.
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "daemon.hpp"

namespace {
using namespace tally::service::test;
using Clock = std::chrono::steady_clock;

constexpr int kClients = 50;
constexpr int kMaxRequestsPerClient = 2000;  // bounds each client's loop by count...
constexpr auto kReadLimit = 150s;            // ...and by time, whatever the capture does
constexpr auto kAfterFinish = 1500ms;        // reads go on this long past the capture's end
// Each client's share, at the least, against the mean over clients: a ratio
// within the run, so that a busy machine (fewer requests for all) does not fail it.
constexpr int kFairShareDivisor = 4;
constexpr size_t kMaxReportedProblems = 20;

// What the clients know before they start.
struct Known {
  int64_t capture = 0;               // the long capture, running while they read
  std::vector<int64_t> runs;         // the first capture's (finished) runs...
  std::vector<int64_t> samples;      // ...their samples...
  std::vector<int64_t> screenshots;  // ...and those of them with a screenshot
};

// Problems and the worst latency, shared by the client threads.
class Findings {
 public:
  void problem(const std::string& what) {
    std::lock_guard lock(mutex_);
    if (problems_.size() < kMaxReportedProblems) problems_.push_back(what);
    ++problemCount_;
  }
  void latency(Clock::duration d) {
    std::lock_guard lock(mutex_);
    maxLatency_ = std::max(maxLatency_, d);
  }
  const std::vector<std::string>& problems() const { return problems_; }
  int problemCount() const { return problemCount_; }
  Clock::duration maxLatency() const { return maxLatency_; }

 private:
  std::mutex mutex_;
  std::vector<std::string> problems_;
  int problemCount_ = 0;
  Clock::duration maxLatency_{};
};

// One client: its own httplib::Client, a round robin over the read endpoints.
class Reader {
 public:
  Reader(int index, int port, const Known& known, Findings& findings)
      : index_(index), client_("127.0.0.1", port), known_(known), findings_(findings) {
    client_.set_connection_timeout(5, 0);
    client_.set_read_timeout(10, 0);  // as the other service tests: a stuck request shows as a timeout
    // Half of them ask for compressed bodies, as browsers (the dashboard) do.
    if (index % 2) client_.set_default_headers({{"Accept-Encoding", "br, gzip, deflate"}});
  }

  template <class Stop>
  void loop(const Stop& stop) {
    for (int round = index_; requests_ < kMaxRequestsPerClient && !stop(); ++round) readOnce(round);
  }
  int requests() const { return requests_; }
  bool sawTheCapturesRuns() const { return sawTheCapturesRuns_; }
  int ingestWindowReads() const { return ingestWindowReads_; }

 private:
  // GET path: the body of a 200, or empty with the problem recorded.
  std::optional<std::string> get(const std::string& path) {
    auto started = Clock::now();
    httplib::Result res = client_.Get(path.c_str());
    findings_.latency(Clock::now() - started);
    ++requests_;
    if (!res) {
      findings_.problem("GET " + path + ": no response (" + httplib::to_string(res.error()) + ")");
      return std::nullopt;
    }
    // SQLite's own words must never reach a client, whatever the status.
    for (const char* leak : {"SQLITE_BUSY", "database is locked"}) {
      if (res->body.find(leak) != std::string::npos)
        findings_.problem("GET " + path + ": '" + leak + "' in " + res->body.substr(0, 200));
    }
    if (res->status != 200) {
      // Every read here must succeed; an "internal" (500) or "unavailable" (503) code names the cause.
      json error = json::parse(res->body, nullptr, false);
      std::string code =
          error.is_object() && error["error"].is_object() ? error["error"].value("code", "") : "";
      findings_.problem("GET " + path + ": HTTP " + std::to_string(res->status) + " (" + code + ") " +
                        res->body.substr(0, 200));
      return std::nullopt;
    }
    return res->body;
  }

  std::optional<json> getJson(const std::string& path) {
    auto body = get(path);
    if (!body) return std::nullopt;
    json j = json::parse(*body, nullptr, false);
    if (!j.is_object()) {
      findings_.problem("GET " + path + ": not a JSON object: " + body->substr(0, 80));
      return std::nullopt;
    }
    return j;
  }

  void getPng(const std::string& path) {
    auto body = get(path);
    if (body && body->compare(0, 8, std::string("\x89PNG\r\n\x1a\n", 8)) != 0)
      findings_.problem("GET " + path + ": not a PNG");
  }

  static int64_t pick(const std::vector<int64_t>& from, int round) {
    return from[static_cast<size_t>(round) % from.size()];
  }

  void readOnce(int round) {
    switch (round % 11) {
      case 0: return readRuns("/api/runs", round);
      case 1: return readRuns("/api/runs?renderer=forward&width=64&height=36", round);
      case 2: return readRunsOfTheCapture(round);
      case 3: return readTwoPages(round);
      case 4: getJson("/api/runs/" + std::to_string(pick(known_.runs, round))); return;
      case 5: getJson("/api/samples/" + std::to_string(pick(known_.samples, round))); return;
      case 6:
        getPng("/api/samples/" + std::to_string(pick(known_.screenshots, round)) + "/screenshot.png");
        return;
      case 7: getJson("/api/captures"); return;
      case 8: return readTheCapture();
      case 9:
        getJson("/api/compare?runs=" + std::to_string(known_.runs[0]) + "," + std::to_string(known_.runs[1]));
        return;
      default: getJson("/api/export?format=json"); return;
    }
  }

  // The long capture's job; counts the reads made while its child had finished
  // but the job was still running: the window of its ingest.
  void readTheCapture() {
    auto job = getJson("/api/captures/" + std::to_string(known_.capture));
    if (!job || (*job)["status"] != "running") return;
    const json& progress = (*job)["progress"];
    if (progress["total"].get<int64_t>() > 0 && progress["done"] == progress["total"]) ++ingestWindowReads_;
  }

  // A listed run has exactly its listed number of samples: it was never seen half-ingested.
  void checkSamples(const json& run) {
    const std::string id = run["id"].dump();
    auto samples = getJson("/api/runs/" + id + "/samples");
    if (!samples) return;
    size_t got = (*samples)["samples"].size();
    if (got == 0 || run["sample_count"] != got)
      findings_.problem("run " + id + ": listed with " + run["sample_count"].dump() + " samples, has " +
                        std::to_string(got));
  }

  // A list (never empty: the first capture's runs are there), and the samples of one of its runs.
  void readRuns(const std::string& path, int round) {
    auto page = getJson(path);
    if (!page) return;
    const json& runs = (*page)["runs"];
    if (runs.empty()) return findings_.problem("GET " + path + ": no runs");
    checkSamples(runs[static_cast<size_t>(round) % runs.size()]);
  }

  // The running capture's runs: none until its ingest commits, then all of them, each complete.
  void readRunsOfTheCapture(int round) {
    const std::string path = "/api/runs?capture=" + std::to_string(known_.capture);
    auto page = getJson(path);
    if (!page) return;
    const json& runs = (*page)["runs"];
    if (runs.empty()) return;
    sawTheCapturesRuns_ = true;
    if (runs.size() != size_t{kLongSpecRuns})
      findings_.problem(path + ": " + std::to_string(runs.size()) + " runs, expected 0 or " +
                        std::to_string(kLongSpecRuns));
    for (const auto& run : runs) {
      if (run["sample_count"] != kLongSpecSamplesPerRun)
        findings_.problem(path + ": run " + run["id"].dump() + " lists " + run["sample_count"].dump() +
                          " samples, expected " + std::to_string(kLongSpecSamplesPerRun));
    }
    checkSamples(runs[static_cast<size_t>(round) % runs.size()]);
  }

  // Two pages of one run by cursor (there are two runs at least): the second continues below the first.
  void readTwoPages(int round) {
    auto first = getJson("/api/runs?limit=1");
    if (!first) return;
    const json& runs = (*first)["runs"];
    if (runs.size() != 1u || !(*first)["next_cursor"].is_string())
      return findings_.problem("GET /api/runs?limit=1: " + first->dump().substr(0, 200));
    auto second = getJson("/api/runs?limit=1&cursor=" + (*first)["next_cursor"].get<std::string>());
    if (!second) return;
    const json& next = (*second)["runs"];
    if (next.size() != 1u || next[0]["id"].get<int64_t>() >= runs[0]["id"].get<int64_t>())
      return findings_.problem("the second page does not continue the first: " +
                               second->dump().substr(0, 200));
    checkSamples(round % 2 ? runs[0] : next[0]);
  }

  int index_;
  httplib::Client client_;
  const Known& known_;
  Findings& findings_;
  int requests_ = 0;
  bool sawTheCapturesRuns_ = false;
  int ingestWindowReads_ = 0;
};

// The runs and samples of a finished capture, through the API.
Known learnCapture(Daemon& d, int64_t capture) {
  Known known;
  json runs = d.request("GET", "/api/runs?capture=" + std::to_string(capture)).j()["runs"];
  for (const auto& run : runs) {
    known.runs.push_back(run["id"]);
    json samples = d.request("GET", "/api/runs/" + run["id"].dump() + "/samples").j()["samples"];
    for (const auto& s : samples) {
      known.samples.push_back(s["id"]);
      if (s["screenshot"].is_string()) known.screenshots.push_back(s["id"]);
    }
  }
  return known;
}

bool finished(const json& job) {
  if (!job.is_object()) return false;
  std::string s = job.value("status", "");
  return s == "done" || s == "failed" || s == "cancelled";
}

TEST(ServiceConcurrency, FiftyClientsReadWhileACaptureRuns) {
  fs::path dir = makeTempDir("tally-service-concurrency");
  Daemon d(dir, dir / "tally.db");
  ASSERT_TRUE(d.start()) << "tallyd serve did not start";

  // Something to read from the start: a small finished capture.
  Reply first = d.request("POST", "/api/captures", tinySpec().dump());
  ASSERT_EQ(first.status, 202) << first.body;
  ASSERT_EQ(d.waitFinished(first.j()["id"]).value("status", ""), "done");
  Known known = learnCapture(d, first.j()["id"]);
  ASSERT_EQ(known.runs.size(), 2u);
  ASSERT_FALSE(known.samples.empty());
  ASSERT_FALSE(known.screenshots.empty());

  // The long capture, caught mid-way.
  Reply posted = d.request("POST", "/api/captures", longSpec().dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  known.capture = posted.j()["id"];
  ASSERT_EQ(d.waitProgress(known.capture).value("status", ""), "running");

  // The clients read until a while after the capture has finished (its
  // ingest commits while it is still "running", so they overlap that too).
  Findings findings;
  std::atomic<bool> stopping{false};
  const auto limit = Clock::now() + kReadLimit;
  auto stop = [&] { return stopping.load() || Clock::now() >= limit; };
  std::vector<std::unique_ptr<Reader>> readers;
  std::vector<std::thread> threads;
  for (int i = 0; i < kClients; ++i) {
    readers.push_back(std::make_unique<Reader>(i, d.port(), known, findings));
    threads.emplace_back([reader = readers.back().get(), &stop] { reader->loop(stop); });
  }
  json job = json::object();
  while (!finished(job) && Clock::now() < limit) {
    std::this_thread::sleep_for(100ms);
    job = d.request("GET", "/api/captures/" + std::to_string(known.capture)).j();
  }
  std::this_thread::sleep_for(kAfterFinish);
  stopping = true;
  for (auto& t : threads) t.join();

  EXPECT_EQ(job.value("status", ""), "done") << job.dump();
  for (const auto& p : findings.problems()) ADD_FAILURE() << p;
  EXPECT_EQ(findings.problemCount(), 0);
  int total = 0, fewest = kMaxRequestsPerClient, sawTheCapturesRuns = 0, ingestWindowReads = 0;
  for (const auto& r : readers) {
    total += r->requests();
    ingestWindowReads += r->ingestWindowReads();
    fewest = std::min(fewest, r->requests());
    sawTheCapturesRuns += r->sawTheCapturesRuns();
  }
  EXPECT_GE(fewest, 1) << "a client was starved";
  EXPECT_GE(fewest * kFairShareDivisor, total / kClients)
      << "a client was starved: " << fewest << " requests against a mean of " << total / kClients;
  EXPECT_GT(sawTheCapturesRuns, 0) << "no client read the runs of the capture once it was ingested";

  // The finished capture: every run with every sample.
  json runs = d.request("GET", "/api/runs?capture=" + std::to_string(known.capture)).j()["runs"];
  ASSERT_EQ(runs.size(), size_t{kLongSpecRuns});
  for (const auto& run : runs) {
    EXPECT_EQ(run["sample_count"], kLongSpecSamplesPerRun);
    json samples = d.request("GET", "/api/runs/" + run["id"].dump() + "/samples").j()["samples"];
    EXPECT_EQ(samples.size(), size_t{kLongSpecSamplesPerRun});
  }

  std::printf(
      "%d clients made %d requests (the fewest by one client: %d); max latency %.1f ms; %d reads found "
      "the capture complete but still running (its result being stored)\n",
      kClients, total, fewest, std::chrono::duration<double, std::milli>(findings.maxLatency()).count(),
      ingestWindowReads);
  EXPECT_EQ(d.stop(SIGTERM), 0);
  fs::remove_all(dir);
}

}  // namespace
