// `tallyd capture` of camera heatmaps on lavapipe: the result carries the
// layout in every run's notes and each sample's cell in its camera, one
// sample per pose; a pose's counts equal those of the same camera captured
// from an explicit "cameras" list (a path that knows nothing of heatmaps);
// and a small floor grid on Sponza (textures cut to 64 px) places every eye
// on the ground storey, 1.7 m up.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>

#include <gtest/gtest.h>

#include "strict.hpp"
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "read_file.hpp"

namespace tally {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class HeatmapRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally-heatmap-run-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  json capture(const json& spec) {
    std::ofstream(dir_ / "spec.json") << spec.dump();
    const fs::path out = dir_ / "result.json";
    std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + (dir_ / "spec.json").string() +
                      " --out " + out.string() + " 2>" + (dir_ / "err").string();
    int rc = WEXITSTATUS(std::system(cmd.c_str()));
    EXPECT_EQ(rc, 0) << test::readFile(dir_ / "err");
    if (rc != 0) return json();
    return json::parse(test::readFile(out));
  }

  fs::path dir_;
};

// Bytes per frame of a sample: every counter of every pass.
double bytesOf(const json& sample) {
  double sum = 0;
  for (const auto& pass : sample["passes"])
    for (const auto& line : pass["resources"]) sum += line["bytes"].get<double>();
  return sum;
}

TEST_F(HeatmapRun, PosesCarryTheirCellsAndCountLikeExplicitCameras) {
  json result = capture({{"renderers", {"deferred", "visbuffer"}},
                         {"scenes", {"atrium"}},
                         {"resolutions", {{32, 18}}},
                         {"heatmap", {{"layout", "floor"}, {"cells", {3, 2}}, {"yaws", 2}}},
                         {"frames", 2},
                         {"counted_frames", 1},
                         {"ceilings", false}});
  ASSERT_TRUE(result.is_object());
  ASSERT_EQ(result["runs"].size(), 2u);
  const json& layout = result["runs"][0]["notes"]["heatmap"];
  ASSERT_EQ(layout["layout"], "floor");
  EXPECT_EQ(layout["scene"], "atrium");
  EXPECT_EQ(result["runs"][1]["notes"]["heatmap"], layout);
  const size_t poses = layout["cells_with_floor"].get<size_t>() * 2;
  ASSERT_GT(poses, 0u);
  json explicitCameras = json::array();
  for (const auto& run : result["runs"]) {
    ASSERT_EQ(run["samples"].size(), poses);
    for (size_t i = 0; i < poses; ++i) {
      const json& camera = run["samples"][i]["camera"];
      const json& cell = camera["heatmap"];
      const int c = cell["column"], r = cell["row"];
      ASSERT_TRUE(layout["floor"][r][c].is_number());
      EXPECT_NEAR(camera["eye"][1].get<double>(), layout["floor"][r][c].get<double>() + 1.7, 2e-3);
      EXPECT_EQ(camera["label"].get<std::string>().rfind("heatmap cell " + std::to_string(c) + "," + std::to_string(r), 0), 0u);
      if (run["renderer"] == "deferred" && i < 2) {
        explicitCameras.push_back({{"eye", camera["eye"]}, {"target", camera["target"]}, {"fov_deg", camera["fov_deg"]}});
      }
    }
  }
  // The first two poses again, as an explicit camera list: the same counts.
  json again = capture({{"renderers", {"deferred"}},
                        {"scenes", {"atrium"}},
                        {"resolutions", {{32, 18}}},
                        {"cameras", explicitCameras},
                        {"frames", 1},
                        {"counted_frames", 1},
                        {"ceilings", false}});
  ASSERT_TRUE(again.is_object());
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(bytesOf(again["runs"][0]["samples"][i]), bytesOf(result["runs"][0]["samples"][i])) << "pose " << i;
    EXPECT_GT(bytesOf(result["runs"][0]["samples"][i]), 0.0);
  }
}

// A scene without a walkable floor (stacked vertical planes) fails the
// capture before any frame, saying why, and writes no result.
TEST_F(HeatmapRun, NoWalkableFloorFailsTheCapture) {
  std::ofstream(dir_ / "spec.json") << json{{"renderers", {"forward"}},
                                            {"scenes", {{{"name", "planes"}, {"layers", 2}}}},
                                            {"resolutions", {{16, 9}}},
                                            {"heatmap", {{"layout", "floor"}, {"cells", {2, 2}}}},
                                            {"frames", 1},
                                            {"ceilings", false}}
                                           .dump();
  const fs::path out = dir_ / "none.json";
  std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + (dir_ / "spec.json").string() +
                    " --out " + out.string() + " 2>" + (dir_ / "err").string();
  EXPECT_NE(WEXITSTATUS(std::system(cmd.c_str())), 0);
  std::string err = test::readFile(dir_ / "err");
  EXPECT_NE(err.find("scenes[0] (planes): heatmap: no cell has a walkable floor"), std::string::npos) << err;
  EXPECT_NE(err.find("\"no_surface\":4"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(HeatmapRun, SponzaSmallGridOnTheGround) {
  const fs::path sponza = fs::path(TALLY_SHARED_SCENES) / "sponza" / "Sponza.gltf";
  if (!fs::exists(sponza)) {
    TALLY_SKIP_UNLESS_STRICT("Sponza not found at " << sponza);
  }
  json result = capture({{"renderers", {"visbuffer"}},
                         {"scenes", {{{"gltf", sponza.string()}, {"max_texture_size", 16}}}},
                         {"resolutions", {{32, 18}}},
                         {"heatmap", {{"layout", "floor"}, {"cells", {6, 3}}, {"yaws", 1}}},
                         {"frames", 1},
                         {"counted_frames", 1},
                         {"ceilings", false}});
  ASSERT_TRUE(result.is_object());
  const json& run = result["runs"][0];
  const json& layout = run["notes"]["heatmap"];
  const double ground = layout["ground"].get<double>();
  // Sponza's bounds are y -1.01 .. 11.43 (the file's accessors x 0.008): the
  // ground storey is near the bottom, the roofs near the top.
  EXPECT_LT(ground, 0.5);
  EXPECT_GT(ground, -1.1);
  // The middle row runs down the courtyard: most of it is floor.
  int middle = 0;
  for (const auto& f : layout["floor"][1]) middle += f.is_number() ? 1 : 0;
  EXPECT_GE(middle, 4) << layout["empty"].dump();
  ASSERT_EQ(run["samples"].size(), layout["cells_with_floor"].get<size_t>());
  for (const auto& sample : run["samples"]) {
    const json& eye = sample["camera"]["eye"];
    EXPECT_LT(std::abs(eye[1].get<double>() - 1.7 - ground), 1.0 + 1e-3);  // on the ground level, never a roof
    EXPECT_LT(sample["sky_fraction"].get<double>(), 1.0);                 // it sees the building
    EXPECT_GT(bytesOf(sample), 0.0);
  }
  std::printf("sponza on lavapipe: ground %.3f, %zu cells with floor, empty %s\n", ground,
              layout["cells_with_floor"].get<size_t>(), layout["empty_counts"].dump().c_str());
}

}  // namespace
}  // namespace tally
