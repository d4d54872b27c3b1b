// `tallyd capture` end to end on lavapipe: the result follows
// docs/result-schema.md, bytes follow the formats, screenshots are written,
// and bad specs fail with the field named.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "renderers/renderer.hpp"

namespace tally {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class CaptureRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally-capture-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  int capture(const json& spec, const std::string& out) {
    std::ofstream(dir_ / "spec.json") << spec.dump();
    std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + (dir_ / "spec.json").string() +
                      " --out " + out + " 2>" + (dir_ / "err").string();
    return WEXITSTATUS(std::system(cmd.c_str()));
  }

  fs::path dir_;
};

TEST_F(CaptureRun, ResultFollowsTheSchema) {
  json spec = {{"renderers", renderers::rendererNames()},
               {"scenes", {{{"name", "planes"}, {"layers", 3}, {"order", "back-to-front"}}}},
               {"resolutions", {{64, 36}}},
               {"cameras", {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}, {"fov_deg", 60}}}},
               {"frames", 2},
               {"lights", 4}};
  fs::path out = dir_ / "result.json";
  ASSERT_EQ(capture(spec, out.string()), 0) << slurp(dir_ / "err");
  json result = json::parse(slurp(out));
  ASSERT_TRUE(result.contains("device"));
  EXPECT_TRUE(result["device"].contains("name"));
  ASSERT_TRUE(result.contains("shaders"));
  EXPECT_EQ(result["shaders"]["forward.frag.glsl"].get<std::string>().size(), 16u);
  ASSERT_EQ(result["runs"].size(), renderers::rendererNames().size());
  for (const auto& run : result["runs"]) {
    SCOPED_TRACE(run["renderer"].get<std::string>());
    EXPECT_EQ(run["scene"], "planes");
    EXPECT_EQ(run["width"], 64);
    EXPECT_EQ(run["height"], 36);
    std::map<std::string, json> resources;
    for (const auto& r : run["resources"]["list"]) {
      resources[r["name"]] = r;
      if (r["kind"] == "attachment") {
        EXPECT_EQ(r["format_bytes"].get<uint64_t>(), 64u * 36u * r["element_bytes"].get<uint64_t>());
        EXPECT_GE(r["allocation_bytes"].get<uint64_t>(), r["format_bytes"].get<uint64_t>());
      }
    }
    EXPECT_GT(run["resources"]["render_target_bytes"].get<uint64_t>(), 0u);
    ASSERT_EQ(run["samples"].size(), 1u);
    const auto& sample = run["samples"][0];
    for (const char* field : {"camera", "sky_fraction", "screenshot", "frame_ms", "overhead_ratio", "passes"}) {
      EXPECT_TRUE(sample.contains(field)) << field;
    }
    EXPECT_TRUE(fs::exists(dir_ / "result-screenshots" / sample["screenshot"].get<std::string>()));
    EXPECT_GT(sample["frame_ms"].get<double>(), 0.0);
    if (run["renderer"] != "forward") {
      EXPECT_TRUE(sample.contains("image_error"));
    }
    std::vector<std::string> passNames;
    for (const auto& pass : sample["passes"]) {
      passNames.push_back(pass["name"]);
      for (const char* field : {"name", "gpu_ms", "fragment_invocations", "resources"}) {
        EXPECT_TRUE(pass.contains(field)) << field;
      }
      for (const auto& r : pass["resources"]) {
        for (const char* field : {"name", "format", "kind", "access", "count", "bytes"}) {
          EXPECT_TRUE(r.contains(field)) << field;
        }
        EXPECT_TRUE(r["access"] == "read" || r["access"] == "write");
        // Bytes follow the format the renderer created (images) ...
        auto info = resources.find(r["name"].get<std::string>());
        if (info != resources.end() && info->second["kind"] != "buffer" && r["source"] == "counter") {
          double perElement = info->second["element_bytes"].get<double>();
          double count = r["count"].get<double>(), bytes = r["bytes"].get<double>();
          if (info->second["kind"] == "depth" && r["access"] == "read") {
            // Sampling the depth aspect of D32_S8 reads its 4 depth bytes.
            EXPECT_DOUBLE_EQ(bytes, count * 4) << r.dump();
          } else {
            EXPECT_DOUBLE_EQ(bytes, count * perElement) << r.dump();
          }
        }
      }
    }
    auto expected = (*renderers::makeRenderer(run["renderer"].get<std::string>()))->passNames();
    EXPECT_EQ(passNames, expected);
  }
}

TEST_F(CaptureRun, BadSpecNamesTheFieldAndWritesNothing) {
  json spec = {{"renderers", {"forward", "warp"}}, {"resolutions", {{64, 36}}}};
  fs::path out = dir_ / "bad.json";
  EXPECT_EQ(capture(spec, out.string()), 1);
  std::string err = slurp(dir_ / "err");
  EXPECT_NE(err.find("renderers[1]: unknown renderer 'warp'"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace tally
