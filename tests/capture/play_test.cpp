// `tallyd play` end to end on lavapipe: every renderer and workload renders
// "planes" and "atrium" as a plain application (exit 0, one line per frame,
// pipeline layouts without the counter set), and bad arguments exit 2 with
// one line naming the flag.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "renderers/renderer.hpp"
#include "shared.h"
#include "read_file.hpp"

namespace tally {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A shell word.
std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

class PlayCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally-play-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  struct Run {
    int code = -1;
    std::string out, err;
  };
  Run play(const std::vector<std::string>& args) {
    std::string cmd = std::string(TALLYD_PATH) + " play";
    for (const auto& a : args) cmd += " " + quote(a);
    cmd += " >" + (dir_ / "out").string() + " 2>" + (dir_ / "err").string();
    Run r;
    r.code = WEXITSTATUS(std::system(cmd.c_str()));
    r.out = test::readFile(dir_ / "out");
    r.err = test::readFile(dir_ / "err");
    return r;
  }

  fs::path dir_;
};

TEST_F(PlayCommand, EveryRendererPlaysPlanesAndAtrium) {
  std::vector<std::string> names = renderers::rendererNames();
  for (const auto& w : renderers::workloadNames()) names.push_back(w);
  for (const std::string scene : {"planes", "atrium"}) {
    for (const auto& name : names) {
      SCOPED_TRACE(name + " on " + scene);
      Run r = play({"--renderer", name, "--scene", scene, "--resolution", "64x36", "--frames", "2", "--json",
                    "--verbose"});
      ASSERT_EQ(r.code, 0) << r.err;
      // The setup line, then one line per frame.
      auto err = lines(r.err);
      ASSERT_EQ(err.size(), 3u) << r.err;
      EXPECT_NE(err[0].find(name + " set up:"), std::string::npos) << err[0];
      EXPECT_NE(err[0].find("debug utils names on, labels on"), std::string::npos) << err[0];
      EXPECT_EQ(err[1].rfind("tallyd play: frame 1/2, ", 0), 0u) << err[1];
      EXPECT_EQ(err[2].rfind("tallyd play: frame 2/2, ", 0), 0u) << err[2];
      json summary = json::parse(r.out);
      EXPECT_EQ(summary["renderer"], name);
      EXPECT_EQ(summary["scene"], scene);
      EXPECT_EQ(summary["frames"], 2);
      EXPECT_EQ(summary["camera"], 0);
      EXPECT_FALSE(summary["passes"].empty());
      // No counter set: the pass inputs are the last set a plain pipeline layout holds.
      EXPECT_GE(summary["max_pipeline_sets"].get<uint32_t>(), shaders::kSetGeometry + 1);
      EXPECT_LE(summary["max_pipeline_sets"].get<uint32_t>(), shaders::kSetPassInput + 1);
      EXPECT_NE(err[0].find("at most " + summary["max_pipeline_sets"].dump() + " descriptor sets"), std::string::npos);
      for (const auto& resource : summary["named"]) EXPECT_GT(resource["objects"].get<int>(), 0) << resource["name"];
    }
  }
}

TEST_F(PlayCommand, OptionsCameraAndQuiet) {
  Run r = play({"--renderer", "deferred", "--options", R"({"gbuffer":"subpass"})", "--scene",
                R"({"name":"planes","layers":2})", "--resolution", "32x18", "--frames", "3", "--camera", "2",
                "--lights", "4", "--quiet", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  json summary = json::parse(r.out);
  EXPECT_EQ(summary["options"], json({{"gbuffer", "subpass"}}));
  EXPECT_EQ(summary["camera"], 2);
  EXPECT_EQ(summary["frames"], 3);
  EXPECT_EQ(summary["passes"], json({"gbuffer", "lighting", "tonemap", "skybox"}));
}

TEST_F(PlayCommand, BadArgumentsExitTwoNamingTheFlag) {
  const std::vector<std::string> ok = {"--renderer", "forward", "--scene", "planes", "--resolution", "64x36",
                                       "--frames", "1"};
  // Replaces (or adds) one flag's value in the good command line; "" drops the flag.
  auto with = [&ok](const std::string& flag, const std::string& value) {
    std::vector<std::string> args;
    bool found = false;
    for (size_t i = 0; i < ok.size(); i += 2) {
      if (ok[i] == flag) {
        found = true;
        if (!value.empty()) args.insert(args.end(), {flag, value});
      } else {
        args.insert(args.end(), {ok[i], ok[i + 1]});
      }
    }
    if (!found) args.insert(args.end(), {flag, value});
    return args;
  };
  struct Case {
    std::vector<std::string> args;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {with("--renderer", ""), "--renderer: required"},
      {with("--renderer", "forwrd"), "--renderer: unknown renderer \"forwrd\" (expected one of forward,"},
      {with("--options", "{\"output\":\"x\"}"), "--options: output: \"x\" is not one of"},
      {with("--options", "{\"output\""), "--options: not valid JSON"},
      {with("--options", "[1]"), "--options: must be an object"},
      {with("--scene", ""), "--scene: required"},
      {with("--scene", "nosuch"), "--scene: unknown scene \"nosuch\""},
      {with("--scene", "{\"name\":\"planes\",\"layers\":0}"), "--scene: layers: must be an integer"},
      {with("--scene", (fs::temp_directory_path() / "tally-no-such.gltf").string()), "--scene: gltf: "},
      {with("--resolution", ""), "--resolution: required"},
      {with("--resolution", "64"), "--resolution: must be WIDTHxHEIGHT"},
      {with("--resolution", "0x36"), "--resolution: must be WIDTHxHEIGHT"},
      {with("--resolution", "16000x16000"), "--resolution: 16000x16000 is more than the"},
      {with("--frames", ""), "--frames: required"},
      {with("--frames", "0"), "--frames: must be an integer from 1 to 1000, got \"0\""},
      {with("--frames", "two"), "--frames: must be an integer"},
      {with("--camera", "99"), "--camera: 99 is past the scene's"},
      {with("--lights", "401"), "--lights: must be an integer from 0 to 400"},
      {with("--device", "no-such-device"), "--device: no Vulkan device matches 'no-such-device'"},
      {with("--bogus", "1"), "tallyd play: "},
  };
  for (const auto& c : cases) {
    std::string shown;
    for (const auto& a : c.args) shown += a + " ";
    SCOPED_TRACE(shown);
    Run r = play(c.args);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("tallyd play: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
  }
}

}  // namespace
}  // namespace tally
