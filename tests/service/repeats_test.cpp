// GET /api/repeats end to end: one spec captured twice on lavapipe. Each
// renderer's two runs form one group, their counts are identical, and every
// figure equals the one recomputed here from /api/runs/{id}/samples and
// /api/samples/{id}; each run's frame time is its frame_ms_median, the one
// every other view shows. Nothing here asserts that the timings agree: the machine
// is shared and noisy (docs/accuracy.md, "Repeatability", reports it).
#include <signal.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daemon.hpp"

namespace {
using namespace tally::service::test;

// Linear interpolation between order statistics, as docs/measurement.md defines percentiles.
double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  double at = p * double(v.size() - 1);
  size_t lo = static_cast<size_t>(at), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (at - double(lo));
}

class RepeatsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-repeats-test");
    daemon_ = new Daemon(dir_, dir_ / "tally.db");
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
  }
  static void TearDownTestSuite() {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0);
    }
    delete daemon_;
    daemon_ = nullptr;
    fs::remove_all(dir_);
  }
  static int64_t capture(const json& spec) {
    Reply r = daemon_->request("POST", "/api/captures", spec.dump());
    EXPECT_EQ(r.status, 202) << r.body;
    int64_t id = r.j().value("id", int64_t{0});
    json job = daemon_->waitFinished(id, std::chrono::seconds(180));
    EXPECT_EQ(job.value("status", ""), "done") << job.dump();
    return id;
  }
  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
};

json spec(int frames) {
  return {{"renderers", {"forward", "deferred"}},
          {"scenes", {"atrium"}},
          {"resolutions", {{64, 36}}},
          {"cameras",
           {{{"eye", {-4.8, 0.728, -3.0}}, {"target", {-4.541, 8.156, -3.0}}, {"fov_deg", 60}},
            {{"eye", {0.0, 1.6, -4.0}}, {"target", {0.0, 1.6, 4.0}}, {"fov_deg", 60}}}},
          {"frames", frames},
          {"lights", 4}};
}

// One run's per-sample figures, from the API's sample routes.
struct Recomputed {
  std::vector<double> frameMs, frameIqr, bytes, bytesIqr;
  std::vector<double> frames;  // every frame of every sample
  std::vector<std::map<std::string, double>> counts;
};

Recomputed recompute(Daemon& d, int64_t runId) {
  Recomputed out;
  json samples = d.request("GET", "/api/runs/" + std::to_string(runId) + "/samples").j()["samples"];
  for (const auto& s : samples) {
    out.frameMs.push_back(s["frame_ms"].get<double>());
    out.frameIqr.push_back(s["frame_ms_spread"]["q3"].get<double>() - s["frame_ms_spread"]["q1"].get<double>());
    out.bytes.push_back(s["bytes"].get<double>());
    json sample = d.request("GET", "/api/samples/" + std::to_string(s["id"].get<int64_t>())).j();
    for (const auto& t : sample["frame_ms_frames"]) out.frames.push_back(t.get<double>());
    double noise = 0;
    std::map<std::string, double> counts;
    for (const auto& pass : sample["passes"]) {
      for (const auto& r : pass["resources"]) {
        double count = r["count"].get<double>();
        counts[pass["name"].get<std::string>() + "/" + r["name"].get<std::string>() + " " +
               r["access"].get<std::string>()] += count;
        if (count > 0 && r["count_spread"].is_object()) {
          noise += (r["count_spread"]["q3"].get<double>() - r["count_spread"]["q1"].get<double>()) *
                   r["bytes"].get<double>() / count;
        }
      }
    }
    out.bytesIqr.push_back(noise);
    out.counts.push_back(std::move(counts));
  }
  return out;
}

void expectFigure(const json& figure, const std::vector<double>& perRun,
                  const std::vector<std::vector<double>>& iqrs, double k, const std::string& what) {
  std::vector<double> pooled;
  for (const auto& v : iqrs) pooled.insert(pooled.end(), v.begin(), v.end());
  ASSERT_EQ(figure["per_run"].size(), perRun.size()) << what;
  for (size_t i = 0; i < perRun.size(); ++i) EXPECT_DOUBLE_EQ(figure["per_run"][i].get<double>(), perRun[i]) << what;
  double median = percentile(perRun, 0.5), noise = percentile(pooled, 0.5);
  EXPECT_DOUBLE_EQ(figure["median"].get<double>(), median) << what;
  EXPECT_DOUBLE_EQ(figure["q1"].get<double>(), percentile(perRun, 0.25)) << what;
  EXPECT_DOUBLE_EQ(figure["q3"].get<double>(), percentile(perRun, 0.75)) << what;
  EXPECT_DOUBLE_EQ(figure["min"].get<double>(), *std::min_element(perRun.begin(), perRun.end())) << what;
  EXPECT_DOUBLE_EQ(figure["max"].get<double>(), *std::max_element(perRun.begin(), perRun.end())) << what;
  EXPECT_DOUBLE_EQ(figure["noise_iqr"].get<double>(), noise) << what;
  EXPECT_DOUBLE_EQ(figure["band_low"].get<double>(), median - k * noise) << what;
  EXPECT_DOUBLE_EQ(figure["band_high"].get<double>(), median + k * noise) << what;
  bool inside = true;
  for (double v : perRun) inside = inside && v >= median - k * noise && v <= median + k * noise;
  EXPECT_EQ(figure["agrees"].get<bool>(), inside) << what;
}

TEST_F(RepeatsTest, SameSpecTwice) {
  int64_t first = capture(spec(4));  // 8 frames a run: enough for a median's interval
  int64_t second = capture(spec(4));
  int64_t other = capture(spec(2));  // other frame count: a different configuration

  Reply r = daemon_->request("GET", "/api/repeats");
  ASSERT_EQ(r.status, 200) << r.body;
  json body = r.j();
  EXPECT_EQ(body["truncated"], false);
  double k = body["band_iqrs"].get<double>();
  EXPECT_GT(k, 0.0);
  json groups = body["groups"];
  ASSERT_EQ(groups.size(), 2u) << r.body;  // forward and deferred; the 2-frame runs have no repeat

  std::map<std::string, int> renderers;
  for (const auto& g : groups) {
    std::string what = g.dump();
    ++renderers[g["renderer"].get<std::string>()];
    ASSERT_EQ(g["runs"].size(), 2u) << what;
    EXPECT_EQ(g["captures"], (json{first, second})) << what;
    EXPECT_EQ(g["width"], 64);
    EXPECT_EQ(g["height"], 36);
    EXPECT_EQ(g["counting"], "accumulate");  // the default
    EXPECT_EQ(g["cameras"], 2);
    EXPECT_EQ(g["frames"], (json{4, 4}));
    std::vector<Recomputed> runs;
    std::vector<double> runMedians;
    for (const auto& id : g["runs"]) {
      json run = daemon_->request("GET", "/api/runs/" + std::to_string(id.get<int64_t>())).j();
      EXPECT_EQ(run["renderer"], g["renderer"]) << what;
      EXPECT_NE(run["capture"], other) << what;
      runs.push_back(recompute(*daemon_, id.get<int64_t>()));
      ASSERT_EQ(runs.back().frameMs.size(), 2u) << what;
      ASSERT_EQ(runs.back().frames.size(), 8u) << what;
      runMedians.push_back(run["frame_ms_median"].get<double>());
    }
    // Exact counting is deterministic: every counter of every camera is equal.
    EXPECT_EQ(runs[0].counts, runs[1].counts) << what;
    size_t counters = runs[0].counts[0].size() + runs[0].counts[1].size();
    EXPECT_GT(counters, 5u);
    EXPECT_EQ(g["counts"]["identical"], true) << what;
    EXPECT_EQ(g["counts"]["counters"], counters) << what;
    EXPECT_TRUE(g["counts"]["first_difference"].is_null()) << what;
    // So are the bytes: equal per run, no noise, and they agree.
    EXPECT_EQ(runs[0].bytes, runs[1].bytes) << what;
    EXPECT_EQ(g["bytes"]["agrees"], true) << what;
    EXPECT_EQ(g["bytes"]["noise_iqr"], 0.0) << what;

    // Frame time: each run's median of all 8 frames, as /api/runs gives it,
    // with the interval of its 1st and 8th order statistics (k = floor(4 -
    // 0.98 sqrt 8) = 1, docs/statistics.md).
    const json& frame = g["frame_ms"];
    EXPECT_EQ(frame["statistic"], "frame_ms_median") << what;
    for (size_t i = 0; i < runs.size(); ++i) {
      EXPECT_DOUBLE_EQ(percentile(runs[i].frames, 0.5), runMedians[i]) << what;
      EXPECT_DOUBLE_EQ(frame["per_run_lower"][i].get<double>(),
                       *std::min_element(runs[i].frames.begin(), runs[i].frames.end()))
          << what;
      EXPECT_DOUBLE_EQ(frame["per_run_upper"][i].get<double>(),
                       *std::max_element(runs[i].frames.begin(), runs[i].frames.end()))
          << what;
      EXPECT_EQ(frame["per_run_source"][i], "frames") << what;
    }
    expectFigure(frame, runMedians, {runs[0].frameIqr, runs[1].frameIqr}, k, "frame_ms " + what);
    // Bytes: each run's mean over its cameras, its mean_bytes.
    EXPECT_EQ(g["bytes"]["statistic"], "mean_bytes") << what;
    std::vector<double> meanBytes;
    for (size_t i = 0; i < runs.size(); ++i) {
      meanBytes.push_back((runs[i].bytes[0] + runs[i].bytes[1]) / 2);
      json run = daemon_->request("GET", "/api/runs/" + g["runs"][i].dump()).j();
      EXPECT_DOUBLE_EQ(run["mean_bytes"].get<double>(), meanBytes.back()) << what;
    }
    expectFigure(g["bytes"], meanBytes, {runs[0].bytesIqr, runs[1].bytesIqr}, k, "bytes " + what);
  }
  EXPECT_EQ(renderers["forward"], 1);
  EXPECT_EQ(renderers["deferred"], 1);

  // Filters select the runs grouped: one renderer, or one capture (no repeats).
  json forward = daemon_->request("GET", "/api/repeats?renderer=forward").j();
  ASSERT_EQ(forward["groups"].size(), 1u) << forward.dump();
  EXPECT_EQ(forward["groups"][0]["renderer"], "forward");
  json one = daemon_->request("GET", "/api/repeats?capture=" + std::to_string(first)).j();
  EXPECT_EQ(one["groups"].size(), 0u) << one.dump();
  json wide = daemon_->request("GET", "/api/repeats?width=65").j();
  EXPECT_EQ(wide["groups"].size(), 0u) << wide.dump();
  Reply bad = daemon_->request("GET", "/api/repeats?frames=3");
  EXPECT_EQ(bad.status, 400) << bad.body;
  EXPECT_NE(bad.body.find("frames"), std::string::npos) << bad.body;
}

}  // namespace
