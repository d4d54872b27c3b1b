// Camera heatmaps end to end on lavapipe: a tiny floor heatmap of the atrium
// (deferred and visbuffer, 4 x 2 cells, 32x18, 3 frames) and a tiny sphere
// heatmap captured through a real `tallyd serve`; GET /api/heatmap checked
// against the samples it names (values, ratios, cells, eye heights, the
// significance 3 frames against 3 can reach), the plan's PNG against the
// layout's image size, the bad requests (400 naming the field, 404), and
// `tally heatmap` printing the grid and the summary.
#include <signal.h>

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "daemon.hpp"

namespace {
using namespace tally::service::test;

class HeatmapRoute : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-heatmap-test");
    daemon_ = new Daemon(dir_, dir_ / "tally.db");
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
    floor_ = capture({{"renderers", {"deferred", "visbuffer"}},
                      {"scenes", {"atrium"}},
                      {"resolutions", {{32, 18}}},
                      {"heatmap", {{"layout", "floor"}, {"cells", {4, 2}}, {"yaws", 2}}},
                      {"frames", 3},
                      {"counted_frames", 1},
                      {"ceilings", false}});
    sphere_ = capture({{"renderers", {"forward"}},
                       {"resolutions", {{32, 18}}},
                       {"heatmap", {{"layout", "sphere"}, {"rings", 2}, {"segments", 3}}},
                       {"frames", 2},
                       {"counted_frames", 1},
                       {"ceilings", false}});
    plain_ = capture({{"renderers", {"forward"}},
                      {"resolutions", {{16, 9}}},
                      {"cameras", {{{"eye", {0, 1.7, -4}}, {"target", {0, 1.7, 4}}}}},
                      {"frames", 1},
                      {"ceilings", false}});
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
  static json get(const std::string& path, int status = 200) {
    Reply r = daemon_->request("GET", path);
    EXPECT_EQ(r.status, status) << path << ": " << r.body;
    return r.j();
  }
  static std::string map(int64_t capture, const std::string& rest) {
    return "/api/heatmap?capture=" + std::to_string(capture) + rest;
  }
  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
  static inline int64_t floor_ = 0, sphere_ = 0, plain_ = 0;
};

TEST_F(HeatmapRoute, FrameTimesRatiosAndCellsComeFromTheSamples) {
  json body = get(map(floor_, "&renderer=deferred&versus=visbuffer&metric=frame_ms"));
  ASSERT_TRUE(body.is_object());
  EXPECT_EQ(body["metric"], "frame_ms");
  EXPECT_EQ(body["yaw"], "mean");
  const json& layout = body["layout"];
  ASSERT_EQ(layout["layout"], "floor");
  ASSERT_EQ(layout["columns"], 4);
  ASSERT_EQ(layout["rows"], 2);
  EXPECT_FALSE(layout.contains("scene"));  // a file path on the daemon's host is not served
  ASSERT_EQ(body["cells"].size(), 8u);
  size_t measured = 0;
  for (const auto& cell : body["cells"]) {
    const int c = cell["column"], r = cell["row"];
    SCOPED_TRACE("cell " + std::to_string(c) + "," + std::to_string(r));
    EXPECT_EQ(cell["floor"], layout["floor"][r][c]);
    if (cell["value_a"].is_null()) {
      EXPECT_FALSE(cell["empty"].is_null());
      continue;
    }
    ++measured;
    ASSERT_EQ(cell["samples_a"].size(), 2u);  // both yaws
    ASSERT_EQ(cell["samples_b"].size(), 2u);
    double sumA = 0, sumB = 0;
    std::vector<double> framesA;
    for (size_t i = 0; i < 2; ++i) {
      json a = get("/api/samples/" + std::to_string(cell["samples_a"][i].get<int64_t>()));
      json b = get("/api/samples/" + std::to_string(cell["samples_b"][i].get<int64_t>()));
      // The sample is this cell's, at this yaw, its eye 1.7 m above the cell's floor.
      EXPECT_EQ(a["camera"]["heatmap"]["column"], c);
      EXPECT_EQ(a["camera"]["heatmap"]["row"], r);
      EXPECT_EQ(a["camera"]["heatmap"]["yaw"], i);
      EXPECT_EQ(b["camera"]["heatmap"], a["camera"]["heatmap"]);
      EXPECT_NEAR(a["camera"]["eye"][1].get<double>(), cell["floor"].get<double>() + 1.7, 2e-3);
      const double x = layout["origin"][0].get<double>() + (c + 0.5) * layout["cell_size"][0].get<double>();
      EXPECT_NEAR(a["camera"]["eye"][0].get<double>(), x, 1e-3);
      sumA += a["frame_ms"].get<double>();
      sumB += b["frame_ms"].get<double>();
      for (const auto& f : a["frame_ms_frames"]) framesA.push_back(f.get<double>());
    }
    EXPECT_NEAR(cell["value_a"].get<double>(), sumA / 2, 1e-9 * sumA);
    EXPECT_NEAR(cell["value_b"].get<double>(), sumB / 2, 1e-9 * sumB);
    EXPECT_NEAR(cell["ratio"].get<double>(), sumB / sumA, 1e-9);
    // The test pools both yaws' frames: 2 x 3 per renderer.
    ASSERT_TRUE(cell["significance"].is_object()) << cell.dump();
    EXPECT_EQ(cell["significance"]["n_a"], framesA.size());
    EXPECT_EQ(framesA.size(), 6u);
    EXPECT_EQ(cell["significant"], cell["verdict"] != "same");
  }
  EXPECT_EQ(measured, body["summary"]["cells_measured"].get<size_t>());
  EXPECT_EQ(measured, layout["cells_with_floor"].get<size_t>());
  EXPECT_GE(measured, 4u);  // the atrium's court is floor (tests/scenes/heatmap_test.cpp)
  const json& s = body["summary"];
  EXPECT_EQ(s["significant"].get<size_t>() + s["not_significant"].get<size_t>(), measured);
  EXPECT_EQ(s["b_lower"].get<size_t>() + s["b_higher"].get<size_t>(), s["significant"].get<size_t>());
  EXPECT_LE(s["ratio"]["min"]["value"].get<double>(), s["ratio"]["median"].get<double>());
  EXPECT_GE(s["ratio"]["max"]["value"].get<double>(), s["ratio"]["median"].get<double>());
  EXPECT_EQ(body["topdown"], "/api/heatmap/" + std::to_string(floor_) + "/topdown.png?scene=atrium");
}

TEST_F(HeatmapRoute, OneYawWorstAndBytes) {
  json mean = get(map(floor_, "&renderer=deferred&versus=visbuffer&metric=bytes"));
  json yaw1 = get(map(floor_, "&renderer=deferred&versus=visbuffer&metric=bytes&yaw=1"));
  json worst = get(map(floor_, "&renderer=deferred&versus=visbuffer&metric=bytes&yaw=worst"));
  json single = get(map(floor_, "&renderer=visbuffer&metric=bytes&yaw=0"));
  for (size_t k = 0; k < mean["cells"].size(); ++k) {
    const json& cell = yaw1["cells"][k];
    if (cell["value_a"].is_null()) continue;
    EXPECT_EQ(cell["yaw"], 1);
    ASSERT_EQ(cell["samples_a"].size(), 1u);
    json a = get("/api/samples/" + std::to_string(cell["samples_a"][0].get<int64_t>()));
    json b = get("/api/samples/" + std::to_string(cell["samples_b"][0].get<int64_t>()));
    EXPECT_EQ(a["camera"]["heatmap"]["yaw"], 1);
    EXPECT_EQ(cell["value_a"].get<double>(), a["bytes"].get<double>());
    // Counts compare exactly.
    EXPECT_EQ(cell["verdict"], a["bytes"] == b["bytes"] ? "same" : "changed");
    // worst: the yaw with the larger ratio.
    const json& w = worst["cells"][k];
    const json y0 = get(map(floor_, "&renderer=deferred&versus=visbuffer&metric=bytes&yaw=0"))["cells"][k];
    EXPECT_DOUBLE_EQ(w["ratio"].get<double>(), std::max(y0["ratio"].get<double>(), cell["ratio"].get<double>()));
    // One renderer: no ratio, no versus.
    EXPECT_TRUE(single["cells"][k]["ratio"].is_null());
    EXPECT_EQ(single["cells"][k]["value_a"], y0["value_b"]);
  }
  EXPECT_TRUE(single["versus"].is_null());
  EXPECT_FALSE(single["summary"].contains("ratio"));
}

TEST_F(HeatmapRoute, TopDownPlanIsAPngOfTheLayoutsSize) {
  json body = get(map(floor_, "&renderer=deferred"));
  Reply png = daemon_->request("GET", "/api/heatmap/" + std::to_string(floor_) + "/topdown.png");
  ASSERT_EQ(png.status, 200) << png.body;
  EXPECT_EQ(png.contentType, "image/png");
  ASSERT_GT(png.body.size(), 24u);
  EXPECT_EQ(png.body.substr(1, 3), "PNG");
  auto be32 = [&](size_t at) {
    const auto* p = reinterpret_cast<const unsigned char*>(png.body.data() + at);
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
  };
  EXPECT_EQ(be32(16), body["layout"]["image"]["width"].get<uint32_t>());
  EXPECT_EQ(be32(20), body["layout"]["image"]["height"].get<uint32_t>());
  // Again, from the cache: the same bytes.
  EXPECT_EQ(daemon_->request("GET", "/api/heatmap/" + std::to_string(floor_) + "/topdown.png?scene=atrium").body, png.body);
  // A sphere has no plan, nor a capture without a heatmap, nor one that does not exist.
  get("/api/heatmap/" + std::to_string(sphere_) + "/topdown.png", 404);
  get("/api/heatmap/" + std::to_string(plain_) + "/topdown.png", 404);
  get("/api/heatmap/999999/topdown.png", 404);
  get("/api/heatmap/" + std::to_string(floor_) + "/topdown.png?scene=sky", 404);
  json bad = get("/api/heatmap/" + std::to_string(floor_) + "/topdown.png?size=2", 400);
  EXPECT_EQ(bad["error"]["field"], "size");
}

TEST_F(HeatmapRoute, SphereCellsAreEveryPose) {
  json body = get(map(sphere_, "&renderer=forward"));
  const json& layout = body["layout"];
  EXPECT_EQ(layout["layout"], "sphere");
  EXPECT_TRUE(body["topdown"].is_null());
  ASSERT_EQ(body["cells"].size(), 6u);
  const double distance = layout["distance"].get<double>();
  for (const auto& cell : body["cells"]) {
    ASSERT_FALSE(cell["value_a"].is_null());
    json a = get("/api/samples/" + std::to_string(cell["samples_a"][0].get<int64_t>()));
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      double e = a["camera"]["eye"][k].get<double>() - layout["center"][k].get<double>();
      d2 += e * e;
      EXPECT_NEAR(a["camera"]["target"][k].get<double>(), layout["center"][k].get<double>(), 1e-4);
    }
    EXPECT_NEAR(std::sqrt(d2), distance, 1e-3 * distance);
    EXPECT_EQ(a["frame_ms"].get<double>(), cell["value_a"].get<double>());
  }
}

TEST_F(HeatmapRoute, BadRequestsNameTheField) {
  struct Case {
    std::string query;
    int status;
    std::string field;
  };
  const std::string f = std::to_string(floor_);
  const std::vector<Case> cases = {
      {"?renderer=deferred", 400, "capture"},
      {"?capture=" + f, 400, "renderer"},
      {"?capture=x&renderer=deferred", 400, "capture"},
      {"?capture=" + f + "&renderer=forward", 400, "renderer"},
      {"?capture=" + f + "&renderer=deferred&versus=forward", 400, "versus"},
      {"?capture=" + f + "&renderer=deferred&versus=deferred", 400, "versus"},
      {"?capture=" + f + "&renderer=deferred&metric=joules", 400, "metric"},
      {"?capture=" + f + "&renderer=deferred&yaw=2", 400, "yaw"},
      {"?capture=" + f + "&renderer=deferred&yaw=north", 400, "yaw"},
      {"?capture=" + f + "&renderer=deferred&scene=sky", 400, "scene"},
      {"?capture=" + f + "&renderer=deferred&colour=red", 400, "colour"},
      {"?capture=" + std::to_string(plain_) + "&renderer=forward", 400, "capture"},
      {"?capture=999999&renderer=deferred", 404, ""},
  };
  for (const auto& c : cases) {
    json body = get("/api/heatmap" + c.query, c.status);
    if (!c.field.empty()) {
      EXPECT_EQ(body["error"]["field"], c.field) << c.query << ": " << body.dump();
    }
  }
  // The renderer error lists the capture's variants.
  json wrong = get("/api/heatmap?capture=" + f + "&renderer=forward", 400);
  EXPECT_NE(wrong["error"]["message"].get<std::string>().find("'deferred', 'visbuffer'"), std::string::npos) << wrong.dump();
  // A bad heatmap spec is refused when posted, naming its field.
  Reply posted = daemon_->request(
      "POST", "/api/captures",
      json{{"renderers", {"forward"}}, {"resolutions", {{8, 8}}}, {"heatmap", {{"layout", "floor"}, {"cells", {4, 0}}}}}.dump());
  EXPECT_EQ(posted.status, 400) << posted.body;
  EXPECT_EQ(posted.j()["error"]["field"], "heatmap.cells[1]") << posted.body;
  // The daemon serves on.
  get("/api/health");
}

TEST_F(HeatmapRoute, CliPrintsTheGridAndSummary) {
  const std::string out = (dir_ / "tally-heatmap.out").string();
  const std::string cmd = std::string(TALLY_PATH) + " --server " + daemon_->url() + " heatmap " +
                          std::to_string(floor_) + " --renderer deferred --versus visbuffer > " + out + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(out);
  std::string text = slurp(out);
  json body = get(map(floor_, "&renderer=deferred&versus=visbuffer"));
  // One line per row, and every measured cell's ratio to two decimals in it.
  for (const auto& cell : body["cells"]) {
    if (cell["ratio"].is_null()) continue;
    char ratio[16];
    std::snprintf(ratio, sizeof ratio, "%.2f", cell["ratio"].get<double>());
    EXPECT_NE(text.find(ratio), std::string::npos) << ratio << " in\n" << text;
  }
  EXPECT_NE(text.find("SUMMARY"), std::string::npos) << text;
  EXPECT_NE(text.find("best for visbuffer (lowest ratio) at cell"), std::string::npos) << text;
  EXPECT_NE(text.find("significant cells: " + std::to_string(body["summary"]["significant"].get<int>()) + " of"),
            std::string::npos)
      << text;
  // A bad renderer: exit 1 with the server's message.
  const std::string bad = std::string(TALLY_PATH) + " --server " + daemon_->url() + " heatmap " +
                          std::to_string(floor_) + " --renderer forward > " + out + " 2>&1";
  EXPECT_NE(std::system(bad.c_str()), 0);
  EXPECT_NE(slurp(out).find("renderer"), std::string::npos) << slurp(out);
}

}  // namespace
