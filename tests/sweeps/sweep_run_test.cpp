// The depth-reconstruction sweep on lavapipe: the measured position error
// tracks the float32 depth step (derived in sweeps/depth.hpp), grows
// with distance and with far/near as that step does, and fails where the
// prediction says; `tallyd capture` routes sweep specs and names bad fields.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "sweeps/sweep.hpp"
#include "renderers/renderer.hpp"
#include "sweep_fixture.hpp"

namespace tally::sweeps {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Measured over predicted max error: the depth is rounded to the nearest
// float (half a step) and worldFromDepth's float inverse adds a few steps more
// (its w = m23 * depth + m33 cancels terms of 1 / near); lavapipe gives 1.2
// to 4.3 over a 54-point sweep (docs/measurement.md).
constexpr double kLowFactor = 0.5, kHighFactor = 5.0;

json sweep(const json& spec) { return fixture::runSpec(spec); }

// far fixed at 1000 m: near 1 and 0.01 are far/near 1e3 and 1e5. Distances
// 100x apart put the predicted relative errors two decades apart, wider than
// the [kLowFactor, kHighFactor] band, so a threshold can sit between them.
json depthSpec(double threshold) {
  return {{"sweep", "depth-reconstruction"}, {"renderer", "deferred"}, {"near", {1.0, 0.01}},
          {"far", {1000.0}}, {"distances", {3.0, 300.0}}, {"resolution", {64, 36}},
          {"threshold", {{"relative", threshold}}}};
}

const json& point(const json& result, double near, double distance) {
  for (const auto& p : result["points"]) {
    if (p["near"] == near && p["distance"] == distance) return p;
  }
  static const json none;
  ADD_FAILURE() << "no point near " << near << " distance " << distance;
  return none;
}

TEST(DepthSweep, ErrorTracksTheFloat32DepthStep) {
  json result = sweep(depthSpec(0.5));
  ASSERT_FALSE(result.is_null());
  EXPECT_EQ(result["sweep"], "depth-reconstruction");
  EXPECT_EQ(result["parameters"], json({"near", "far", "distance"}));
  EXPECT_TRUE(result["device"].contains("name"));
  ASSERT_EQ(result["points"].size(), 4u);
  EXPECT_TRUE(result["fails_at"].is_null());  // nothing reaches half the distance
  EXPECT_TRUE(result["predicted_fails_at"].is_null());
  for (const auto& p : result["points"]) {
    SCOPED_TRACE(p.dump());
    EXPECT_EQ(p["error"]["pixels"], 64 * 36);
    double ratio = p["error"]["max_abs"].get<double>() / p["predicted"]["max_abs"].get<double>();
    EXPECT_GE(ratio, kLowFactor);
    EXPECT_LE(ratio, kHighFactor);
    EXPECT_DOUBLE_EQ(p["error_over_predicted"].get<double>(), ratio);
    // The predicted step at the plane's centre, from the formula directly.
    double n = double(float(p["near"].get<double>())), f = double(float(p["far"].get<double>()));
    double d = p["distance"].get<double>();
    EXPECT_LE(depthStepDistance(d, d, n, f), p["predicted"]["max_abs"].get<double>());
  }
  // Relative step = ulp(D) (f - n) t / (f n): x100 with distance (100x apart),
  // x100 with far/near at fixed far (near 1 -> 0.01), while D stays in [0.5, 1).
  for (double near : {1.0, 0.01}) {
    const auto &a = point(result, near, 3), &b = point(result, near, 300);
    double predictedGrowth = b["predicted"]["max_relative"].get<double>() / a["predicted"]["max_relative"].get<double>();
    EXPECT_NEAR(predictedGrowth, 100.0, 1.0);
    double measuredGrowth = b["error"]["max_relative"].get<double>() / a["error"]["max_relative"].get<double>();
    EXPECT_GE(measuredGrowth, predictedGrowth * kLowFactor / kHighFactor);
    EXPECT_LE(measuredGrowth, predictedGrowth * kHighFactor / kLowFactor);
  }
  for (double distance : {3.0, 300.0}) {
    const auto &a = point(result, 1.0, distance), &b = point(result, 0.01, distance);
    double predictedGrowth = b["predicted"]["max_relative"].get<double>() / a["predicted"]["max_relative"].get<double>();
    EXPECT_NEAR(predictedGrowth, (1000 - 0.01) / 0.01 / ((1000 - 1) / 1.0), 1.0);
    double measuredGrowth = b["error"]["max_relative"].get<double>() / a["error"]["max_relative"].get<double>();
    EXPECT_GE(measuredGrowth, predictedGrowth * kLowFactor / kHighFactor);
  }
}

TEST(DepthSweep, FailsWhereThePredictionCrossesTheThreshold) {
  // The threshold: ten times the predicted relative error at near 1, distance
  // 3 (m steps), i.e. a tenth of the next decade's. Above it by the band:
  // near 0.01 at both distances and near 1 at 300.
  json probe = sweep(depthSpec(0.5));
  ASSERT_FALSE(probe.is_null());
  double threshold = 10 * point(probe, 1.0, 3)["predicted"]["max_relative"].get<double>();
  json result = sweep(depthSpec(threshold));
  ASSERT_FALSE(result.is_null());
  EXPECT_EQ(result["threshold"]["relative"], threshold);
  ASSERT_FALSE(result["fails_at"].is_null());
  EXPECT_EQ(result["fails_at"], result["predicted_fails_at"]);
  json distance = {{{"near", 1.0}, {"far", 1000.0}, {"distance", 300.0}},
                   {{"near", 0.01}, {"far", 1000.0}, {"distance", 3.0}}};
  EXPECT_EQ(result["fails_at"]["distance"], distance);
  // Per distance, the smallest far/near that fails: near 0.01 (1e5) at 3 m, near 1 (1e3) at 300 m.
  const auto& ratio = result["fails_at"]["far_over_near"];
  ASSERT_EQ(ratio.size(), 2u);
  EXPECT_EQ(ratio[0]["distance"], 3.0);
  EXPECT_NEAR(ratio[0]["far_over_near"].get<double>(), 1e5, 1e-6);
  EXPECT_EQ(ratio[1]["distance"], 300.0);
  EXPECT_NEAR(ratio[1]["far_over_near"].get<double>(), 1e3, 1e-9);
}

// The value at a dotted path into a point ("error.max_relative"), or null.
json at(const json& point, const std::string& dotted) {
  json v = point;
  std::stringstream parts(dotted);
  for (std::string key; std::getline(parts, key, '.');) {
    if (!v.is_object() || !v.contains(key)) return nullptr;
    v = v[key];
  }
  return v;
}

// The plots (docs/result-schema.md, "Sweep results"): each names fields every
// point has, and its lines are exactly the groups fails_at states a value for
// (points that differ only in the plot's x), whichever end the spec fixed.
TEST(DepthSweep, PlotsDrawTheFailsAtGroups) {
  json byFar = depthSpec(1e-4);
  json byRatio = depthSpec(0.5);
  byRatio.erase("far");
  byRatio["far_over_near"] = {1e3, 1e5};
  byRatio["near"] = {1.0, 2.0};
  byRatio["threshold"] = {{"absolute", 0.01}};
  byRatio["resolution"] = {32, 18};
  for (const json& spec : {byFar, byRatio}) {
    json result = sweep(spec);
    ASSERT_FALSE(result.is_null());
    const bool relative = spec["threshold"].contains("relative");
    const std::string fixedEnd = spec.contains("far") ? "far" : "near";
    const double threshold = relative ? spec["threshold"]["relative"].get<double>() : 0.01;
    ASSERT_EQ(result["plots"].size(), 2u);
    const json expected[] = {{{"x", "distance"}, {"series", {"near", "far"}}},
                             {{"x", "far_over_near"}, {"series", {"distance", fixedEnd}}}};
    for (size_t k = 0; k < 2; ++k) {
      const json& plot = result["plots"][k];
      SCOPED_TRACE(plot.dump());
      EXPECT_EQ(plot["x"], expected[k]["x"]);
      EXPECT_EQ(plot["series"], expected[k]["series"]);
      EXPECT_EQ(plot["y"], relative ? "error.max_relative" : "error.max_abs");
      EXPECT_EQ(plot["x_log"], true);
      EXPECT_EQ(plot["y_log"], true);
      EXPECT_EQ(plot["threshold"], threshold);
      EXPECT_TRUE(plot["title"].is_string() && plot["y_label"].is_string());
      // Lines: one per distinct series value; within one, x never repeats.
      std::map<std::vector<double>, std::set<double>> lines;
      for (const auto& p : result["points"]) {
        ASSERT_TRUE(at(p, plot["y"]).is_number()) << p.dump();
        std::vector<double> key;
        for (const auto& field : plot["series"]) key.push_back(at(p, field).get<double>());
        EXPECT_TRUE(lines[key].insert(at(p, plot["x"]).get<double>()).second) << "x repeats in a line";
      }
      // fails_at's groups for this axis, where something fails, are the same lines.
      const json& groups = result["fails_at"].is_null() ? json() : result["fails_at"][plot["x"].get<std::string>()];
      if (groups.is_array()) {
        std::set<std::vector<double>> stated;
        for (const auto& g : groups) {
          std::vector<double> key;
          for (const auto& field : plot["series"]) key.push_back(g[field.get<std::string>()].get<double>());
          stated.insert(key);
        }
        std::set<std::vector<double>> drawn;
        for (const auto& [key, unused] : lines) drawn.insert(key);
        EXPECT_EQ(stated, drawn);
      }
    }
  }
}

class SweepCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally-sweep-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  int capture(const json& spec) {
    std::ofstream(dir_ / "spec.json") << spec.dump();
    std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + (dir_ / "spec.json").string() +
                      " --out " + (dir_ / "result.json").string() + " 2>" + (dir_ / "err").string();
    return WEXITSTATUS(std::system(cmd.c_str()));
  }
  std::string slurp(const std::string& name) {
    std::ifstream in(dir_ / name);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir_;
};

TEST_F(SweepCommand, CaptureRoutesSweepSpecs) {
  json spec = depthSpec(1e-3);
  spec["distances"] = {3.0};
  spec["near"] = {1.0};
  ASSERT_EQ(capture(spec), 0) << slurp("err");
  json result = json::parse(slurp("result.json"));
  EXPECT_EQ(result["sweep"], "depth-reconstruction");
  EXPECT_EQ(result["spec"], spec);
  EXPECT_EQ(result["points"].size(), 1u);
  EXPECT_FALSE(result.contains("runs"));

  spec["distances"] = {3.0, 2000.0};
  EXPECT_EQ(capture(spec), 1);
  EXPECT_NE(slurp("err").find("spec: distances[1]: the plane at 2000"), std::string::npos) << slurp("err");
  EXPECT_FALSE(fs::exists(dir_ / "result.json.tmp"));
}

}  // namespace
}  // namespace tally::sweeps
