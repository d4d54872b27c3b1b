// GET /api/crossover over stored synthetic captures: results of known fixed
// and per-pixel cost (plus a small deterministic wobble) ingested into a
// database that a real `tallyd serve` then answers from. The fits recover the
// costs, the crossings are where they were built, a series with too few
// resolutions says why, and the filters and bad requests behave.
#include <signal.h>

#include <cmath>

#include <gtest/gtest.h>

#include "../store/store_fixture.hpp"
#include "daemon.hpp"

namespace {
using namespace tally::service::test;
namespace st = tally::store::testing;

struct Line {
  std::string renderer;
  double a, b;  // bytes per frame = a + b * pixels
};

// Ten 16:9 resolutions, 640x360 to 3840x2160.
std::vector<std::pair<int, int>> resolutions() {
  std::vector<std::pair<int, int>> r;
  for (int i = 0; i < 10; ++i) {
    int h = 360 + i * 200;
    r.emplace_back(static_cast<int>(std::lround(h * 16.0 / 9.0)), h);
  }
  return r;
}

// The wobble: +-0.2% of the value, alternating with the resolution's index.
double wobble(size_t i) { return (i % 2 ? 1.0 : -1.0) * 0.002 * (1.0 + double(i % 3)); }

// One run per line and resolution, one sample of one pass with one counter
// holding the bytes; frame time 1 ms + 1 ms per megapixel for all.
json captureOf(const std::vector<Line>& lines, const std::string& scene,
               const std::vector<std::pair<int, int>>& res) {
  std::vector<json> runs;
  for (const auto& line : lines) {
    for (size_t i = 0; i < res.size(); ++i) {
      auto [w, h] = res[i];
      double pixels = double(w) * h;
      double bytes = (line.a + line.b * pixels) * (1.0 + wobble(i));
      double ms = 1.0 + pixels * 1e-6 * (1.0 + wobble(i + 1));
      json pass = st::makePass("main", ms, pixels, {st::makeCounter("target", "write", bytes / 4, bytes)});
      runs.push_back(st::makeRun(line.renderer, scene, w, h, {st::makeSample(0, ms, {pass})}));
    }
  }
  return st::makeCapture(std::move(runs));
}

class CrossoverRoute : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-crossover-test");
    fs::path db = dir_ / "tally.db";
    {
      auto store = st::openStore(db.string());
      ASSERT_NE(store, nullptr);
      auto ingest = [&](const json& result) {
        auto job = store->jobs().create({{"renderers", {"forward"}}});
        EXPECT_TRUE(job) << job.error();
        auto stored = store->runs().ingestCapture(job->job.id, result, {});
        EXPECT_TRUE(stored) << stored.error();
        EXPECT_TRUE(store->jobs().finish(job->job.id, tally::store::JobStatus::Done));
        return job->job.id;
      };
      // deferred 1 MB + 40 B/px, visbuffer 9 MB + 30 B/px: cross at 800,000 pixels.
      // forward 0.5 MB + 45 B/px: crosses deferred at 100,000 (below the range),
      // visbuffer at 566,667. forward-zprepass: deferred's slope, 3 MB more.
      std::vector<Line> lines = {{"deferred", 1e6, 40.0},
                                 {"visbuffer", 9e6, 30.0},
                                 {"forward", 0.5e6, 45.0},
                                 {"forward-zprepass", 4e6, 40.0}};
      json result = captureOf(lines, "atrium", resolutions());
      // Two runs of deferred on the sky scene: too few for a fit.
      json sky = captureOf({{"deferred", 1e6, 40.0}}, "sky", {{640, 360}, {1280, 720}});
      for (auto& run : sky["runs"]) result["runs"].push_back(run);
      sweep_ = ingest(result);
      // A capture of one resolution: no fits at all.
      single_ = ingest(captureOf({{"deferred", 1e6, 40.0}, {"visbuffer", 9e6, 30.0}}, "atrium", {{1280, 720}}));
    }
    daemon_ = new Daemon(dir_, db, {"--role", "api"});
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
  static json get(const std::string& path, int status = 200) {
    Reply r = daemon_->request("GET", path);
    EXPECT_EQ(r.status, status) << path << ": " << r.body;
    return r.j();
  }
  static const json& series(const json& body, const std::string& variant, const std::string& scene = "atrium") {
    for (const auto& s : body["series"]) {
      if (s["variant"] == variant && s["scene"] == scene) return s;
    }
    static const json none;
    ADD_FAILURE() << "no series " << variant << " on " << scene << " in " << body.dump();
    return none;
  }
  static const json& crossing(const json& body, const std::string& first, const std::string& second) {
    for (const auto& c : body["crossings"]) {
      if (c["first"] == first && c["second"] == second) return c;
    }
    static const json none;
    ADD_FAILURE() << "no crossing " << first << "/" << second << " in " << body.dump();
    return none;
  }
  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
  static inline int64_t sweep_ = 0, single_ = 0;
};

TEST_F(CrossoverRoute, FitsRecoverTheCosts) {
  json body = get("/api/crossover?capture=" + std::to_string(sweep_) + "&metric=bytes");
  EXPECT_EQ(body["capture"], sweep_);
  EXPECT_EQ(body["metric"], "bytes");
  EXPECT_EQ(body["truncated"], false);
  EXPECT_EQ(body["series"].size(), 5u) << body.dump();  // four on the atrium, deferred on the sky
  for (auto [variant, a, b] : {std::tuple{"deferred", 1e6, 40.0}, {"visbuffer", 9e6, 30.0}, {"forward", 0.5e6, 45.0}}) {
    const json& fit = series(body, variant)["fit"];
    ASSERT_TRUE(fit.is_object()) << variant;
    EXPECT_EQ(fit["n"], 10);
    EXPECT_NEAR(fit["b"].get<double>(), b, 0.01 * b) << variant;
    EXPECT_LE(fit["b_ci"][0].get<double>(), fit["b"].get<double>());
    EXPECT_GE(fit["b_ci"][1].get<double>(), fit["b"].get<double>());
    EXPECT_GT(fit["r2"].get<double>(), 0.999) << variant;
    EXPECT_EQ(fit["poor_fit"], false);
    ASSERT_EQ(fit["points"].size(), 10u);
    double sum = 0;
    for (const auto& p : fit["points"]) {
      EXPECT_EQ(p["pixels"].get<double>(), p["width"].get<double>() * p["height"].get<double>());
      double predicted = fit["a"].get<double>() + fit["b"].get<double>() * p["pixels"].get<double>();
      EXPECT_NEAR(p["residual"].get<double>(), p["value"].get<double>() - predicted, 1e-6 * p["value"].get<double>());
      sum += p["residual"].get<double>();
    }
    EXPECT_NEAR(sum, 0.0, 1.0) << variant;
    EXPECT_EQ(series(body, variant)["runs"].size(), 10u);
    EXPECT_TRUE(series(body, variant)["error"].is_null());
    // The fixed cost planted: the wobble (up to 0.6 % of values of up to
    // 330 MB) moves the least-squares intercept by about 1-2.5 % of it here
    // (worked out by hand from the same points); its interval holds the truth.
    EXPECT_NEAR(fit["a"].get<double>(), a, 0.05 * a) << variant;
    EXPECT_LE(fit["a_ci"][0].get<double>(), a) << variant;
    EXPECT_GE(fit["a_ci"][1].get<double>(), a) << variant;
    EXPECT_LE(fit["a_ci"][0].get<double>(), fit["a"].get<double>());
    EXPECT_GE(fit["a_ci"][1].get<double>(), fit["a"].get<double>());
  }
  const json& sky = series(body, "deferred", "sky");
  EXPECT_TRUE(sky["fit"].is_null());
  EXPECT_NE(sky["error"].get<std::string>().find("at least 3 resolutions, got 2"), std::string::npos) << sky.dump();
}

TEST_F(CrossoverRoute, CrossingsWhereConstructed) {
  json body = get("/api/crossover?capture=" + std::to_string(sweep_));  // bytes by default
  EXPECT_EQ(body["metric"], "bytes");
  EXPECT_EQ(body["crossings"].size(), 6u) << body.dump();  // the atrium's 4 variants pairwise; the sky alone
  const json& dv = crossing(body, "deferred", "visbuffer");
  EXPECT_EQ(dv["kind"], "crosses") << dv.dump();
  EXPECT_NEAR(dv["pixels"].get<double>(), 800000, 40000) << dv.dump();
  EXPECT_LE(dv["pixels_ci"][0].get<double>(), dv["pixels"].get<double>());
  EXPECT_GE(dv["pixels_ci"][1].get<double>(), dv["pixels"].get<double>());
  EXPECT_EQ(dv["lower_below"], "deferred");
  EXPECT_EQ(dv["lower_above"], "visbuffer");
  EXPECT_TRUE(dv["lower_throughout"].is_null());
  EXPECT_NEAR(dv["resolution"]["width"].get<double>(), 1193, 40);
  EXPECT_NEAR(dv["resolution"]["height"].get<double>(), 671, 25);
  EXPECT_EQ(dv["resolution_ci"].size(), 2u);
  EXPECT_EQ(dv["interval_method"], "fieller");
  EXPECT_EQ(dv["significant"], true);
  EXPECT_EQ(dv["degrees_of_freedom"], 16);
  EXPECT_EQ(dv["scene"], "atrium");

  // Built to cross at 100,000 pixels, below 640x360, with slopes 5 per
  // pixel apart: the estimate lies below the range, but Fieller's interval
  // reaches into it, so that deferred is lower throughout is not established.
  const json& df = crossing(body, "deferred", "forward");
  EXPECT_EQ(df["kind"], "no_significant_crossing") << df.dump();
  EXPECT_EQ(df["significant"], false);
  EXPECT_TRUE(df["lower_throughout"].is_null());
  EXPECT_LT(df["pixels"].get<double>(), 640.0 * 360.0);
  EXPECT_GT(df["pixels_ci"][1].get<double>(), 640.0 * 360.0);
  EXPECT_NE(df["why"].get<std::string>().find("reaches into it"), std::string::npos) << df.dump();

  const json& vf = crossing(body, "visbuffer", "forward");
  EXPECT_EQ(vf["kind"], "crosses") << vf.dump();
  EXPECT_NEAR(vf["pixels"].get<double>(), 566667, 40000);
  EXPECT_EQ(vf["lower_below"], "forward");

  const json& dz = crossing(body, "deferred", "forward-zprepass");
  EXPECT_EQ(dz["kind"], "parallel") << dz.dump();
  EXPECT_TRUE(dz["pixels"].is_null());
  EXPECT_EQ(dz["lower_throughout"], "deferred");
}

TEST_F(CrossoverRoute, FrameTimeAndFilters) {
  json ms = get("/api/crossover?capture=" + std::to_string(sweep_) + "&metric=frame_ms&scene=atrium");
  EXPECT_EQ(ms["series"].size(), 4u) << ms.dump();
  const json& fit = series(ms, "deferred")["fit"];
  EXPECT_NEAR(fit["b"].get<double>(), 1e-6, 1e-8);
  EXPECT_NEAR(fit["a"].get<double>(), 1.0, 0.05);
  // Every renderer has the same frame time: parallel lines.
  EXPECT_EQ(crossing(ms, "deferred", "visbuffer")["kind"], "parallel");
  json sky = get("/api/crossover?capture=" + std::to_string(sweep_) + "&scene=sky");
  EXPECT_EQ(sky["series"].size(), 1u);
  EXPECT_TRUE(sky["crossings"].empty());
  json device = get("/api/crossover?capture=" + std::to_string(sweep_) + "&device=nothing");
  EXPECT_TRUE(device["series"].empty());
}

TEST_F(CrossoverRoute, OneResolutionHasNoFit) {
  json body = get("/api/crossover?capture=" + std::to_string(single_));
  ASSERT_EQ(body["series"].size(), 2u);
  for (const auto& s : body["series"]) {
    EXPECT_TRUE(s["fit"].is_null());
    EXPECT_NE(s["error"].get<std::string>().find("at least 3 resolutions, got 1"), std::string::npos) << s.dump();
  }
  EXPECT_TRUE(body["crossings"].empty());
}

TEST_F(CrossoverRoute, BadRequests) {
  EXPECT_EQ(get("/api/crossover", 400)["error"]["field"], "capture");
  EXPECT_EQ(get("/api/crossover?capture=" + std::to_string(sweep_) + "&metric=watts", 400)["error"]["field"], "metric");
  EXPECT_EQ(get("/api/crossover?capture=0", 400)["error"]["field"], "capture");
  EXPECT_EQ(get("/api/crossover?capture=" + std::to_string(sweep_) + "&width=3", 400)["error"]["field"], "width");
  get("/api/crossover?capture=987654", 404);
}

}  // namespace
