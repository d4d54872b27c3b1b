// Application and replay specs (docs/result-schema.md, "Applications"): the
// defaults, every refusal naming its field; the result built from the layer's
// output; where the layer's manifest is found; the environment the
// application gets. No process is started here (application_run_test.cpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <string>

#include "capture/application.hpp"
#include "capture/spec.hpp"
#include "common/paths.hpp"

namespace tally::capture {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A folder of the test's own, removed afterwards.
struct TempFolder {
  fs::path path;
  TempFolder() {
    std::string pattern = (fs::temp_directory_path() / "tally-appspec-XXXXXX").string();
    path = mkdtemp(pattern.data());
  }
  ~TempFolder() { fs::remove_all(path); }
};

// Sets an environment variable for the test's duration, restoring it after.
struct ScopedEnv {
  std::string name;
  std::optional<std::string> before;
  ScopedEnv(std::string n, const std::optional<std::string>& value) : name(std::move(n)) {
    if (const char* v = std::getenv(name.c_str())) before = v;
    if (value) {
      setenv(name.c_str(), value->c_str(), 1);
    } else {
      unsetenv(name.c_str());
    }
  }
  ~ScopedEnv() {
    if (before) {
      setenv(name.c_str(), before->c_str(), 1);
    } else {
      unsetenv(name.c_str());
    }
  }
};

Result<ApplicationSpec> parse(const std::string& text, const fs::path& base = {}) {
  return parseApplicationSpec(json::parse(text), base);
}

TEST(ApplicationSpec, Defaults) {
  auto spec = parse(R"({"application": {"command": ["sh", "-c", "true"]}})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(spec->kind, ApplicationSpec::Kind::Application);
  EXPECT_EQ(spec->frames, 10u);
  EXPECT_EQ(spec->skipFrames, 0u);
  EXPECT_EQ(spec->frameSubmits, 0u);
  EXPECT_EQ(spec->display, ApplicationSpec::Display::None);
  EXPECT_TRUE(spec->env.empty());
  EXPECT_EQ(spec->timeoutSeconds, 300u);
  EXPECT_EQ(spec->counting, "accumulate");
  EXPECT_EQ(spec->name, "");
  EXPECT_EQ(spec->command, (std::vector<std::string>{"sh", "-c", "true"}));
  // A bare program name is looked up on $PATH.
  EXPECT_TRUE(fs::path(spec->program).is_absolute()) << spec->program;
  EXPECT_EQ(fs::path(spec->program).filename(), "sh");
  EXPECT_TRUE(isApplicationSpec(json::parse(R"({"application": 1})")));
  EXPECT_TRUE(isApplicationSpec(json::parse(R"({"replay": "x"})")));
  EXPECT_FALSE(isApplicationSpec(json::parse(R"({"renderers": ["forward"]})")));
}

TEST(ApplicationSpec, EveryField) {
  auto spec = parse(R"({"application": {"command": ["/bin/sh", "-c", "true"], "frames": 1000, "skip_frames": 100000,
    "frame_submits": 3, "env": {"MY_VAR": "a b", "EMPTY": ""}, "display": "xvfb", "name": "cube", "timeout_s": 3600},
    "counting": "exact"})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(spec->program, "/bin/sh");
  EXPECT_EQ(spec->frames, 1000u);
  EXPECT_EQ(spec->skipFrames, 100000u);
  EXPECT_EQ(spec->frameSubmits, 3u);
  EXPECT_EQ(spec->display, ApplicationSpec::Display::Xvfb);
  EXPECT_EQ(spec->name, "cube");
  EXPECT_EQ(spec->timeoutSeconds, 3600u);
  EXPECT_EQ(spec->counting, "exact");
  ASSERT_EQ(spec->env.size(), 2u);
  EXPECT_EQ(spec->env[0], (std::pair<std::string, std::string>{"EMPTY", ""}));
  EXPECT_EQ(spec->env[1], (std::pair<std::string, std::string>{"MY_VAR", "a b"}));
}

TEST(ApplicationSpec, RelativeProgramAndReplayAreTakenBesideTheSpec) {
  TempFolder dir;
  fs::create_directories(dir.path / "bin");
  std::ofstream(dir.path / "bin" / "app") << "#!/bin/sh\n";
  fs::permissions(dir.path / "bin" / "app", fs::perms::owner_all);
  std::ofstream(dir.path / "trace.gfxr") << "gfxr";
  auto app = parse(R"({"application": {"command": ["bin/app"]}})", dir.path);
  ASSERT_TRUE(app.ok()) << app.error();
  EXPECT_EQ(app->program, (dir.path / "bin" / "app").string());
  EXPECT_EQ(app->command[0], "bin/app");  // as given

  auto replay = parse(R"({"replay": "trace.gfxr", "frames": 3, "skip_frames": 2, "display": "xvfb", "env": {"A": "1"},
    "timeout_s": 60, "frame_submits": 1, "counting": "exact"})", dir.path);
  ASSERT_TRUE(replay.ok()) << replay.error();
  EXPECT_EQ(replay->kind, ApplicationSpec::Kind::Replay);
  EXPECT_EQ(replay->replayFile, (dir.path / "trace.gfxr").string());
  EXPECT_EQ(replay->frames, 3u);
  EXPECT_EQ(replay->skipFrames, 2u);
  EXPECT_EQ(replay->frameSubmits, 1u);
  EXPECT_EQ(replay->timeoutSeconds, 60u);
  EXPECT_EQ(replay->display, ApplicationSpec::Display::Xvfb);
  EXPECT_EQ(replay->counting, "exact");
  EXPECT_EQ(replay->fieldPrefix(), "");
  auto defaults = parse(R"({"replay": "trace.gfxr"})", dir.path);
  ASSERT_TRUE(defaults.ok()) << defaults.error();
  EXPECT_EQ(defaults->frames, 10u);
}

// Every refusal names its field first, as the service's 400 takes it.
TEST(ApplicationSpec, ErrorsNameTheField) {
  TempFolder dir;
  std::ofstream(dir.path / "notexec") << "x";
  std::ofstream(dir.path / "trace.gfxr") << "gfxr";
  fs::create_directories(dir.path / "folder.gfxr");
  struct Case {
    std::string spec, error;
  };
  const std::vector<Case> cases = {
      {R"({"application": "vkcube"})", "application: must be an object with \"command\", got \"vkcube\""},
      {R"({"application": {}})", "application.command: required"},
      {R"({"application": {"command": []}})", "application.command: must be a non-empty array of strings, got []"},
      {R"({"application": {"command": "vkcube"}})", "application.command: must be a non-empty array of strings"},
      {R"({"application": {"command": ["sh", 5]}})", "application.command[1]: must be a string, got 5"},
      {R"({"application": {"command": [""]}})", "application.command[0]: must be a non-empty string"},
      {R"({"application": {"command": ["no-such-program-tally"]}})",
       "application.command[0]: 'no-such-program-tally' is not an executable in any folder of $PATH"},
      {R"({"application": {"command": ["/no/such/file"]}})", "application.command[0]: /no/such/file: no such file"},
      {R"({"application": {"command": ["./notexec"]}})", "application.command[0]: " + (dir.path / "notexec").string() +
                                                             ": not an executable file"},
      {R"({"application": {"command": ["sh"], "frames": 0}})",
       "application.frames: must be an integer between 1 and 1000, got 0"},
      {R"({"application": {"command": ["sh"], "frames": 1001}})",
       "application.frames: must be an integer between 1 and 1000, got 1001"},
      {R"({"application": {"command": ["sh"], "frames": "10"}})",
       "application.frames: must be an integer between 1 and 1000, got \"10\""},
      {R"({"application": {"command": ["sh"], "skip_frames": -1}})",
       "application.skip_frames: must be an integer between 0 and 100000, got -1"},
      {R"({"application": {"command": ["sh"], "skip_frames": 100001}})",
       "application.skip_frames: must be an integer between 0 and 100000, got 100001"},
      {R"({"application": {"command": ["sh"], "frame_submits": 1.5}})",
       "application.frame_submits: must be an integer between 0 and 100000, got 1.5"},
      {R"({"application": {"command": ["sh"], "timeout_s": 0}})",
       "application.timeout_s: must be an integer between 1 and 3600, got 0"},
      {R"({"application": {"command": ["sh"], "timeout_s": 3601}})",
       "application.timeout_s: must be an integer between 1 and 3600, got 3601"},
      {R"({"application": {"command": ["sh"], "display": "wayland"}})",
       "application.display: must be \"none\" or \"xvfb\", got \"wayland\""},
      {R"({"application": {"command": ["sh"], "env": ["A=1"]}})",
       "application.env: must be an object of NAME: \"value\""},
      {R"({"application": {"command": ["sh"], "env": {"A": 1}}})", "application.env.A: must be a string, got 1"},
      {R"({"application": {"command": ["sh"], "env": {"A=B": "1"}}})", "application.env.A=B: not a variable name"},
      {R"({"application": {"command": ["sh"], "env": {"TALLY_LAYER_FRAMES": "3"}}})",
       "application.env.TALLY_LAYER_FRAMES: is set by Tally"},
      {R"({"application": {"command": ["sh"], "env": {"TALLY_LAYER_OUTPUT": "/tmp/x"}}})",
       "application.env.TALLY_LAYER_OUTPUT: is set by Tally"},
      {R"({"application": {"command": ["sh"], "env": {"VK_INSTANCE_LAYERS": "X"}}})",
       "application.env.VK_INSTANCE_LAYERS: is set by Tally"},
      {R"({"application": {"command": ["sh"], "env": {"VK_ADD_LAYER_PATH": "/x"}}})",
       "application.env.VK_ADD_LAYER_PATH: is set by Tally"},
      {R"({"application": {"command": ["sh"], "env": {"VK_LOADER_LAYERS_DISABLE": "*"}}})",
       "application.env.VK_LOADER_LAYERS_DISABLE: is set by Tally"},
      {R"({"application": {"command": ["sh"], "env": {"VK_LAYER_PATH": "/x"}}})",
       "application.env.VK_LAYER_PATH: is set by Tally"},
      {R"({"application": {"command": ["sh"], "display": "xvfb", "env": {"DISPLAY": ":9"}}})",
       "application.env.DISPLAY: is set by \"display\": \"xvfb\""},
      {R"({"application": {"command": ["sh"], "name": ""}})", "application.name: must be a non-empty string"},
      {R"({"application": {"command": ["sh"], "name": 3}})", "application.name: must be a string, got 3"},
      {R"({"application": {"command": ["sh"], "fps": 3}})",
       "application.fps: unknown field (expected command, frames, skip_frames, frame_submits, env, display, name, "
       "timeout_s)"},
      {R"({"application": {"command": ["sh"]}, "frames": 3})", "frames: unknown field (expected application, counting, sites, draws)"},
      {R"({"application": {"command": ["sh"]}, "counting": "subgroup"})",
       "counting: must be \"accumulate\" or \"exact\" (the layer's modes), got \"subgroup\""},
      {R"({"application": {"command": ["sh"]}, "counting": ["exact"]})", "counting: must be \"accumulate\" or \"exact\""},
      // The fields of a capture matrix or a sweep do not go with an application.
      {R"({"application": {"command": ["sh"]}, "renderers": ["forward"]})",
       "renderers: not allowed with \"application\""},
      {R"({"application": {"command": ["sh"]}, "workloads": ["raytrace"]})", "workloads: not allowed with \"application\""},
      {R"({"application": {"command": ["sh"]}, "scenes": ["atrium"]})", "scenes: not allowed with \"application\""},
      {R"({"application": {"command": ["sh"]}, "resolutions": [[8, 8]]})", "resolutions: not allowed with \"application\""},
      {R"({"application": {"command": ["sh"]}, "cameras": "auto"})", "cameras: not allowed with \"application\""},
      {R"({"application": {"command": ["sh"]}, "sweep": "depth-reconstruction"})", "sweep: not allowed with \"application\""},
      {R"({"application": {"command": ["sh"]}, "replay": "trace.gfxr"})", "replay: cannot be combined with \"application\""},
      {R"({"replay": "trace.gfxr", "renderers": ["forward"]})", "renderers: not allowed with \"replay\""},
      {R"({"replay": 5})", "replay: must be the path of a GFXReconstruct capture file, got 5"},
      {R"({"replay": "missing.gfxr"})", "replay: " + (dir.path / "missing.gfxr").string() + ": no such file"},
      {R"({"replay": "folder.gfxr"})", "replay: " + (dir.path / "folder.gfxr").string() + ": not a file"},
      {R"({"replay": "trace.gfxr", "frames": 0})", "frames: must be an integer between 1 and 1000, got 0"},
      {R"({"replay": "trace.gfxr", "timeout_s": 0})", "timeout_s: must be an integer between 1 and 3600, got 0"},
      {R"({"replay": "trace.gfxr", "env": {"TALLY_LAYER_COUNTING": "exact"}})", "env.TALLY_LAYER_COUNTING: is set by Tally"},
      {R"({"replay": "trace.gfxr", "name": "x"})",
       "name: unknown field (expected replay, frames, skip_frames, frame_submits, env, display, timeout_s, counting, sites, draws)"},
  };
  for (const auto& c : cases) {
    auto spec = parse(c.spec, dir.path);
    ASSERT_FALSE(spec.ok()) << c.spec;
    EXPECT_EQ(spec.error().rfind(c.error, 0), 0u) << c.spec << "\n  got:      " << spec.error()
                                                  << "\n  expected: " << c.error;
  }
}

TEST(ApplicationSpec, UnreadableReplayIsNamed) {
  if (geteuid() == 0) GTEST_SKIP() << "root reads any file";
  TempFolder dir;
  std::ofstream(dir.path / "locked.gfxr") << "gfxr";
  fs::permissions(dir.path / "locked.gfxr", fs::perms::none);
  auto spec = parse(R"({"replay": "locked.gfxr"})", dir.path);
  ASSERT_FALSE(spec.ok());
  EXPECT_EQ(spec.error(), "replay: " + (dir.path / "locked.gfxr").string() + ": cannot be read");
}

TEST(ApplicationSpec, FindOnPath) {
  EXPECT_EQ(fs::path(findOnPath("sh", "/nowhere:/bin:/usr/bin")).filename(), "sh");
  EXPECT_EQ(findOnPath("sh", "/nowhere"), "");
  EXPECT_EQ(findOnPath("bin/sh", "/"), "");  // only bare names
}

// ---- where the layer is, and what the application is given -------------------

TEST(LayerDirectory, EnvironmentThenBuildTreeThenInstallTree) {
  TempFolder dir;
  fs::create_directories(dir.path / "build" / "server");
  fs::create_directories(dir.path / "build" / "layer");
  fs::create_directories(dir.path / "prefix" / "bin");
  fs::create_directories(dir.path / "prefix" / "share" / "vulkan" / "explicit_layer.d");
  fs::create_directories(dir.path / "elsewhere");
  {
    ScopedEnv unset("TALLY_LAYER_PATH", std::nullopt);
    auto none = layerDirectory(dir.path / "build" / "server");
    ASSERT_FALSE(none.ok());
    EXPECT_NE(none.error().find("no Vulkan layer manifest (VkLayer_tally_counters.json)"), std::string::npos) << none.error();
    EXPECT_NE(none.error().find((dir.path / "build" / "layer").string()), std::string::npos) << none.error();
    EXPECT_NE(none.error().find("TALLY_LAYER_PATH"), std::string::npos) << none.error();

    std::ofstream(dir.path / "build" / "layer" / kLayerManifest) << "{}";
    std::ofstream(dir.path / "prefix" / "share" / "vulkan" / "explicit_layer.d" / kLayerManifest) << "{}";
    auto build = layerDirectory(dir.path / "build" / "server");
    ASSERT_TRUE(build.ok()) << build.error();
    EXPECT_EQ(*build, dir.path / "build" / "layer");
    auto installed = layerDirectory(dir.path / "prefix" / "bin");
    ASSERT_TRUE(installed.ok()) << installed.error();
    EXPECT_EQ(*installed, dir.path / "prefix" / "share" / "vulkan" / "explicit_layer.d");
  }
  {
    ScopedEnv set("TALLY_LAYER_PATH", (dir.path / "elsewhere").string());
    // Set, it wins, and a folder without the manifest is an error (not a fall-through).
    auto wrong = layerDirectory(dir.path / "build" / "server");
    ASSERT_FALSE(wrong.ok());
    EXPECT_NE(wrong.error().find("$TALLY_LAYER_PATH (" + (dir.path / "elsewhere").string() + ") holds no"),
              std::string::npos)
        << wrong.error();
    std::ofstream(dir.path / "elsewhere" / kLayerManifest) << "{}";
    auto chosen = layerDirectory(dir.path / "build" / "server");
    ASSERT_TRUE(chosen.ok()) << chosen.error();
    EXPECT_EQ(*chosen, dir.path / "elsewhere");
  }
}

TEST(LayerEnvironment, LoaderLayerAndSpec) {
  auto spec = parse(R"({"application": {"command": ["sh"], "frames": 4, "skip_frames": 7, "frame_submits": 2,
    "env": {"MY_VAR": "x"}}, "counting": "exact"})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  auto env = layerEnvironment(*spec, "/layers", "/tmp/out.json");
  std::map<std::string, std::string> m(env.begin(), env.end());
  EXPECT_EQ(m["VK_ADD_LAYER_PATH"], "/layers");
  EXPECT_EQ(m["VK_INSTANCE_LAYERS"], "VK_LAYER_TALLY_counters");
  EXPECT_EQ(m["VK_LOADER_LAYERS_ENABLE"], "VK_LAYER_TALLY_counters");
  EXPECT_EQ(m["TALLY_LAYER_OUTPUT"], "/tmp/out.json");
  EXPECT_EQ(m["TALLY_LAYER_FRAMES"], "4");
  EXPECT_EQ(m["TALLY_LAYER_SKIP_FRAMES"], "7");
  EXPECT_EQ(m["TALLY_LAYER_FRAME_SUBMITS"], "2");
  EXPECT_EQ(m["TALLY_LAYER_COUNTING"], "exact");
  EXPECT_EQ(m["TALLY_LAYER_DRAWS"], "0");
  EXPECT_EQ(m["MY_VAR"], "x");
  EXPECT_EQ(env.back(), (std::pair<std::string, std::string>{"MY_VAR", "x"}));  // the spec's last
}

// ---- the result built from the layer's output ---------------------------------

json layerOutput(int frames, bool complete = true) {
  json out = {{"complete", complete},
              {"layer", {{"name", "VK_LAYER_TALLY_counters"}, {"version", "0.1.0"}, {"counting", "exact"},
                         {"descriptor_set", 7}, {"frame_delimiter", "present"}}},
              {"application", {{"name", "vkcube"}, {"engine", ""}, {"executable", "/usr/bin/vkcube"}}},
              {"device", {{"name", "llvmpipe (LLVM 15.0.6, 256 bits)"}, {"vendorID", "0x10005"}, {"deviceID", "0x0"},
                          {"driverInfo", "Mesa 22.3.6"}, {"apiVersion", "1.3.230"}, {"timestamps", true},
                          {"pipeline_statistics", true}}},
              {"extent", {500, 400}},
              {"resources", {{{"name", "swapchain"}, {"kind", "attachment"}, {"format", "B8G8R8A8_UNORM"},
                              {"element_bytes", 4}, {"width", 500}, {"height", 400}, {"samples", 1},
                              {"allocation_bytes", 800000}, {"usage", "color_attachment|transfer_src"}, {"memory", ""}},
                             {{"name", "buffer 0x5634"}, {"kind", "buffer"}, {"format", ""}, {"element_bytes", 0},
                              {"width", 0}, {"height", 0}, {"samples", 1}, {"allocation_bytes", 4096},
                              {"usage", "uniform_buffer"}, {"memory", ""}}}},
              {"shaders", {{{"name", "shader 0x55"}, {"stage", "fragment"}, {"instrumented", true}, {"sites", 3}, {"reason", ""}},
                           {{"name", "shader 0x56"}, {"stage", "vertex"}, {"instrumented", false}, {"sites", 0},
                            {"reason", "OpCapability Foo is not supported"}}}},
              {"notes", {"pipeline layout 0x1 uses every descriptor set the device allows (8): its pipelines run unchanged, uncounted"}},
              {"frames", json::array()}};
  for (int f = 0; f < frames; ++f) {
    out["frames"].push_back(
        {{"index", 12 + f}, {"submissions", 1}, {"frame_ms", 1.93},
         {"passes", {{{"name", "render pass 0"}, {"gpu_ms", 1.25}, {"draws", 1}, {"dispatches", 0},
                      {"fragment_invocations", 200000}, {"fragment_invocations_statistic", 200000},
                      {"vertex_invocations", 36}, {"compute_invocations", 0}, {"compute_invocations_statistic", -1},
                      {"resources", {{{"name", "swapchain"}, {"kind", "attachment"}, {"format", "B8G8R8A8_UNORM"},
                                      {"access", "write"}, {"count", 200000}, {"bytes", 800000}, {"source", "counter"}},
                                     {{"name", "buffer 0x5634"}, {"kind", "buffer"}, {"format", ""}, {"access", "read"},
                                      {"count", 36}, {"bytes", 2304}, {"source", "counter"}}}}}}}});
  }
  return out;
}

ApplicationSpec cubeSpec(uint32_t frames = 2) {
  auto spec = parse(R"({"application": {"command": ["sh", "--c", "100"], "frames": )" + std::to_string(frames) + "}}");
  EXPECT_TRUE(spec.ok()) << spec.error();
  return *spec;
}

TEST(ApplicationResult, OneRunOneSamplePerFrame) {
  auto result = applicationResult(cubeSpec(), layerOutput(2));
  ASSERT_TRUE(result.ok()) << result.error();
  const json& r = *result;
  EXPECT_EQ(r["device"]["name"], "llvmpipe (LLVM 15.0.6, 256 bits)");
  EXPECT_TRUE(r["tally"]["version"].is_string());
  EXPECT_EQ(r["spec"]["application"]["frames"], 2);
  ASSERT_EQ(r["runs"].size(), 1u);
  const json& run = r["runs"][0];
  EXPECT_EQ(run["renderer"], "app:vkcube");  // the layer's application name
  EXPECT_EQ(run["variant"], "app:vkcube");
  EXPECT_EQ(run["scene"], "sh --c 100");
  EXPECT_EQ(run["width"], 500);
  EXPECT_EQ(run["height"], 400);
  EXPECT_EQ(run["counting"], "exact");  // the layer's
  EXPECT_EQ(run["notes"]["timing"], "instrumented");
  EXPECT_EQ(run["notes"]["layer"]["descriptor_set"], 7);
  ASSERT_EQ(run["notes"]["uninstrumented_shaders"].size(), 1u);
  EXPECT_EQ(run["notes"]["uninstrumented_shaders"][0]["reason"], "OpCapability Foo is not supported");
  ASSERT_EQ(run["notes"]["layer_notes"].size(), 1u);
  EXPECT_EQ(run["notes"]["source"]["kind"], "application");
  EXPECT_EQ(run["notes"]["source"]["command"], json({"sh", "--c", "100"}));
  EXPECT_EQ(run["resources"]["render_target_bytes"], 800000);
  ASSERT_EQ(run["resources"]["list"].size(), 2u);
  EXPECT_EQ(run["resources"]["list"][0]["format_bytes"], 800000);
  EXPECT_FALSE(run["resources"]["list"][1].contains("format_bytes"));  // a buffer
  ASSERT_EQ(run["samples"].size(), 2u);
  const json& sample = run["samples"][1];
  EXPECT_EQ(sample["camera"]["label"], "frame 13");
  EXPECT_EQ(sample["camera"]["index"], 1);
  EXPECT_EQ(sample["camera"]["frame"], 13);
  EXPECT_DOUBLE_EQ(sample["frame_ms"].get<double>(), 1.25);  // the sum of the passes' gpu_ms
  EXPECT_EQ(sample["sky_fraction"], -1);
  ASSERT_EQ(sample["passes"].size(), 1u);
  const json& pass = sample["passes"][0];
  EXPECT_EQ(pass["name"], "render pass 0");
  EXPECT_EQ(pass["fragment_invocations_statistic"], 200000);
  EXPECT_FALSE(pass.contains("compute_invocations"));  // no dispatches
  EXPECT_FALSE(pass.contains("gpu_ms_instrumented"));
  ASSERT_EQ(pass["resources"].size(), 2u);
  EXPECT_EQ(pass["resources"][0]["name"], "swapchain");
  EXPECT_EQ(pass["resources"][0]["access"], "write");
  EXPECT_EQ(pass["resources"][0]["bytes"], 800000);
  EXPECT_DOUBLE_EQ(sample["bytes"].get<double>(), 802304);
}

TEST(ApplicationResult, Names) {
  json output = layerOutput(2);
  ApplicationSpec spec = cubeSpec();
  spec.name = "cube";
  EXPECT_EQ(applicationRunName(spec, output), "app:cube");  // the spec's name first
  spec.name.clear();
  output["application"]["name"] = "";
  EXPECT_EQ(applicationRunName(spec, output), "app:sh");  // then command[0]'s basename
  EXPECT_EQ(applicationRunName(spec), "app:sh");
  TempFolder dir;
  std::ofstream(dir.path / "frames.gfxr") << "gfxr";
  auto replay = parse(R"({"replay": "frames.gfxr"})", dir.path);
  ASSERT_TRUE(replay.ok()) << replay.error();
  EXPECT_EQ(applicationRunName(*replay, output), "replay:frames.gfxr");
  auto result = applicationResult(*replay, layerOutput(10));
  ASSERT_TRUE(result.ok()) << result.error();
  EXPECT_EQ((*result)["runs"][0]["scene"], (dir.path / "frames.gfxr").string());
  EXPECT_EQ((*result)["runs"][0]["notes"]["source"]["kind"], "replay");
}

TEST(ApplicationResult, FewerFramesThanAskedFail) {
  auto incomplete = applicationResult(cubeSpec(5), layerOutput(2, false));
  ASSERT_FALSE(incomplete.ok());
  EXPECT_NE(incomplete.error().find("only 2 of the 5 frames asked for arrived"), std::string::npos) << incomplete.error();
  EXPECT_NE(incomplete.error().find("complete: false"), std::string::npos) << incomplete.error();
  // Incomplete but with every frame asked for: kept, and marked.
  auto enough = applicationResult(cubeSpec(2), layerOutput(2, false));
  ASSERT_TRUE(enough.ok()) << enough.error();
  EXPECT_EQ((*enough)["runs"][0]["notes"]["layer_complete"], false);
}

TEST(ApplicationResult, MissingTimestampsAndExtent) {
  json output = layerOutput(1);
  output["frames"][0]["passes"][0]["gpu_ms"] = -1;
  output.erase("extent");
  auto result = applicationResult(cubeSpec(1), output);
  ASSERT_TRUE(result.ok()) << result.error();
  const json& run = (*result)["runs"][0];
  EXPECT_EQ(run["samples"][0]["passes"][0]["gpu_ms"], 0);
  EXPECT_EQ(run["samples"][0]["frame_ms"], 0);
  EXPECT_TRUE(run["notes"]["gpu_time"].is_string());
  EXPECT_EQ(run["width"], 500);  // the largest image's
  EXPECT_TRUE(run["notes"]["extent"].is_string());
}

TEST(ApplicationResult, MalformedOutputIsNamed) {
  struct Case {
    std::function<void(json&)> edit;
    std::string error;
  };
  const std::vector<Case> cases = {
      {[](json& o) { o.erase("device"); }, "device: missing"},
      {[](json& o) { o["device"].erase("name"); }, "device.name: missing"},
      {[](json& o) { o["frames"] = json::array(); }, "frames: missing or empty"},
      {[](json& o) { o["frames"] = 3; }, "frames: must be an array"},
      {[](json& o) { o["frames"][1]["passes"][0]["gpu_ms"] = "fast"; }, "frames[1].passes[0].gpu_ms: must be a number"},
      {[](json& o) { o["frames"][0]["passes"][0].erase("name"); }, "frames[0].passes[0].name: missing"},
      {[](json& o) { o["frames"][0]["passes"][0]["resources"][1]["access"] = "rw"; },
       "frames[0].passes[0].resources[1].access: must be \"read\" or \"write\""},
      {[](json& o) { o["frames"][0]["passes"][0]["resources"][0]["bytes"] = -1; },
       "frames[0].passes[0].resources[0].bytes: must not be negative"},
      {[](json& o) { o["resources"][0]["width"] = "wide"; }, "resources[0].width: must be an integer"},
      {[](json& o) { o["extent"] = {1}; }, "extent: must be [width, height]"},
  };
  for (const auto& c : cases) {
    json output = layerOutput(2);
    c.edit(output);
    auto result = applicationResult(cubeSpec(), output);
    ASSERT_FALSE(result.ok()) << c.error;
    EXPECT_EQ(result.error().rfind("the layer's output is malformed: ", 0), 0u) << result.error();
    EXPECT_NE(result.error().find(c.error), std::string::npos) << result.error() << "\n  expected: " << c.error;
  }
}

// TALLY_LAYER_DRAWS from the spec's "draws", and from its "sites" (which counts per draw too).
TEST(LayerEnvironment, DrawsFromDrawsOrSites) {
  for (const auto& [fields, draws] : std::vector<std::pair<std::string, std::string>>{
           {R"("draws": true)", "1"}, {R"("sites": true)", "1"}, {R"("draws": false)", "0"}}) {
    auto spec = parse(R"({"application": {"command": ["sh"]}, )" + fields + "}");
    ASSERT_TRUE(spec.ok()) << spec.error();
    auto env = layerEnvironment(*spec, "/layers", "/tmp/out.json");
    std::map<std::string, std::string> m(env.begin(), env.end());
    EXPECT_EQ(m["TALLY_LAYER_DRAWS"], draws) << fields;
  }
  auto bad = parse(R"({"application": {"command": ["sh"]}, "draws": 1})");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("draws: must be true or false", 0), 0u) << bad.error();
}

// The layer's per-draw list becomes the pass's "draws" in the built-in
// renderers' shape, its rest "draws_rest"; the draw commands stay in "draw_count".
TEST(ApplicationResult, DrawListIsThePassDraws) {
  json output = layerOutput(1);
  json& pass = output["frames"][0]["passes"][0];
  pass["draw_list"] = {{{"index", 0}, {"name", "cube \u00b7 textured"}, {"label", "cube"}, {"pipeline", "textured"},
                        {"count", 200036}, {"bytes_read", 2304}, {"bytes_written", 800000}, {"bytes", 802304}}};
  pass["draws_rest"] = {{"draws", 2}, {"count", 0}, {"bytes_read", 0}, {"bytes_written", 0}, {"bytes", 0}};
  auto result = applicationResult(cubeSpec(1), output);
  ASSERT_TRUE(result.ok()) << result.error();
  const json& p = (*result)["runs"][0]["samples"][0]["passes"][0];
  EXPECT_EQ(p["draw_count"], 1);
  ASSERT_TRUE(p["draws"].is_array());
  EXPECT_EQ(p["draws"][0], json({{"index", 0}, {"name", "cube \u00b7 textured"}, {"count", 200036.0},
                                 {"bytes_read", 2304.0}, {"bytes_written", 800000.0}, {"bytes", 802304.0}}));
  EXPECT_EQ(p["draws_rest"]["draws"], 2);
  // Without the list, "draws" stays the number of draw commands.
  auto plain = applicationResult(cubeSpec(1), layerOutput(1));
  ASSERT_TRUE(plain.ok()) << plain.error();
  EXPECT_EQ((*plain)["runs"][0]["samples"][0]["passes"][0]["draws"], 1);

  pass["draw_list"][0]["bytes_read"] = -1;
  auto negative = applicationResult(cubeSpec(1), output);
  ASSERT_FALSE(negative.ok());
  EXPECT_NE(negative.error().find("frames[0].passes[0].draw_list[0]: count and bytes must not be negative"),
            std::string::npos) << negative.error();
  pass["draw_list"][0]["bytes_read"] = 1;
  pass["draws_rest"]["draws"] = 0;
  auto noRest = applicationResult(cubeSpec(1), output);
  ASSERT_FALSE(noRest.ok());
  EXPECT_NE(noRest.error().find("frames[0].passes[0].draws_rest.draws: must be at least 1"), std::string::npos)
      << noRest.error();
}

}  // namespace
}  // namespace tally::capture
