#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>

#include "capture/application.hpp"
#include "capture/application_policy.hpp"
#include "capture/runner.hpp"
#include "capture/spec.hpp"
#include "capture/summary.hpp"
#include "commands/commands.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/renderer.hpp"
#include "sweeps/sweep.hpp"

namespace tally::cli {
namespace {

// Writes the result JSON to --out (temp file + rename: a reader never sees a
// half-written result) or standard output.
int writeResult(const CaptureArgs& args, const nlohmann::json& result) {
  std::string dump = result.dump(1);
  if (args.out.empty() || args.out == "-") {
    std::cout << dump << "\n";
    return 0;
  }
  std::string temp = args.out + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << dump << "\n";
    if (!out) {
      std::cerr << "tallyd capture: " << args.out << ": write failed\n";
      return 1;
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, args.out, ec);
  if (ec) {
    std::cerr << "tallyd capture: " << args.out << ": " << ec.message() << "\n";
    return 1;
  }
  return 0;
}

// An application (or a replay) under the layer: one run, one sample per frame.
// Relative paths in the spec are taken beside the spec file.
int runApplicationCapture(const CaptureArgs& args, const nlohmann::json& json) {
  auto fail = [](const std::string& message) {
    std::cerr << "tallyd capture: " << message << "\n";
    return 1;
  };
  std::filesystem::path base;
  if (args.spec != "-") base = std::filesystem::absolute(args.spec).parent_path();
  capture::ApplicationOptions options;
  if (!args.runAs.empty()) {
    if (geteuid() != 0) {
      return fail("--run-as " + args.runAs + ": tallyd must run as root to run applications as another user");
    }
    auto user = jobs::lookupUser(args.runAs);
    if (!user) return fail("--run-as: " + user.error());
    options.runAs = std::move(*user);
  }
  Result<capture::ApplicationSpec> spec = makeError("not parsed");
  if (args.confineApplications) {
    // The daemon's job: its policy again, on this host, just before the program runs.
    if (geteuid() == 0 && !options.runAs)
      return fail("refusing to run an application as root (tallyd serve --run-as USER)");
    capture::ApplicationPolicy policy;
    auto roots = capture::checkApplicationRoots(args.applicationRoots);
    if (!roots) return fail(roots.error());
    policy.roots = std::move(*roots);
    for (const auto& pattern : args.applicationEnv) {
      if (auto checked = capture::checkApplicationEnvPattern(pattern); !checked) return fail(checked.error());
      policy.env.push_back(pattern);
    }
    spec = capture::parseConfinedApplicationSpec(json, policy);
  } else {
    spec = capture::parseApplicationSpec(json, base);
  }
  if (!spec) return fail("spec: " + spec.error());
  if (!args.out.empty() && args.out != "-") {
    options.tempRoot = std::filesystem::absolute(args.out).parent_path();
  }
  options.progress = [&args](const Progress& p) {
    if (args.quiet) return;
    std::cerr << "[" << p.done << "/" << p.total << "] " << p.current << "\n";
  };
  Result<nlohmann::json> result = makeError("not run");
  try {
    result = capture::runApplication(*spec, options);
  } catch (const std::exception& e) {
    return fail(std::string("capture failed: ") + e.what());
  }
  if (!result) return fail(result.error());
  int written = writeResult(args, *result);
  if (written == 0 && args.summary && !args.out.empty() && args.out != "-") std::cout << capture::summarize(*result);
  return written;
}

}  // namespace

int runCapture(const CaptureArgs& args) {
  auto fail = [](const std::string& message) {
    std::cerr << "tallyd capture: " << message << "\n";
    return 1;
  };
  std::string text;
  if (args.spec == "-") {
    text.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
  } else {
    std::ifstream in(args.spec, std::ios::binary);
    if (!in) return fail(args.spec + ": cannot open for reading");
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  auto json = nlohmann::json::parse(text, nullptr, false);
  if (json.is_discarded()) return fail("spec: not valid JSON");
  // "device" picks a fleet's host (docs/fleet.md); here --device picks the GPU.
  if (json.is_object() && json.contains("device")) {
    if (!args.quiet) std::fprintf(stderr, "tallyd capture: the spec's \"device\" is for a fleet's queue; --device picks the GPU here\n");
    json.erase("device");
  }
  // {"application": ...} or {"replay": ...}: an application under the Vulkan layer.
  if (capture::isApplicationSpec(json)) return runApplicationCapture(args, json);
  // A spec with "sweep" is a stability sweep (sweeps/sweep.hpp), not a capture matrix.
  const bool sweep = sweeps::isSweepSpec(json);
  Result<sweeps::SweepSpec> sweepSpec = makeError("not a sweep");
  Result<capture::CaptureSpec> spec = makeError("not a capture matrix");
  if (sweep) {
    sweepSpec = sweeps::parseSweepSpec(json, renderers::rendererNames());
    if (!sweepSpec) return fail("spec: " + sweepSpec.error());
  } else {
    spec = capture::parseCaptureSpec(json, renderers::rendererNames());
    if (!spec) return fail("spec: " + spec.error());
    // A relative glTF path names a file beside the spec, never one in the
    // working directory (the daemon resolves against its --scenes folders).
    for (size_t i = 0; i < spec->scenes.size(); ++i) {
      auto& scene = spec->scenes[i];
      if (!scene.is_object() || !scene.contains("gltf") || !scene["gltf"].is_string()) continue;
      const std::filesystem::path given = scene["gltf"].get<std::string>();
      if (given.is_absolute()) continue;
      if (args.spec == "-") {
        return fail("spec: scenes[" + std::to_string(i) + "].gltf: the relative path \"" + given.string() +
                    "\" needs a spec file to resolve against (--spec FILE); with --spec - give an absolute path");
      }
      scene["gltf"] = (std::filesystem::absolute(args.spec).parent_path() / given).lexically_normal().string();
    }
  }

  capture::CaptureOptions options;
  options.device = args.device;
  if (!args.out.empty() && args.out != "-") {
    std::filesystem::path out(args.out);
    options.screenshotDir = (out.parent_path() / (out.stem().string() + "-screenshots")).string();
  }
  options.progress = [&args](const Progress& p) {
    if (args.quiet) return;
    std::cerr << "[" << p.done << "/" << p.total << "] " << p.current << "\n";
  };
  Result<nlohmann::json> result = makeError("not run");
  try {
    result = sweep ? capture::runSweep(*sweepSpec, options) : capture::runCapture(*spec, options);
  } catch (const gpu::VulkanError& e) {
    return fail(std::string("Vulkan error: ") + e.what());
  } catch (const std::exception& e) {
    return fail(std::string("capture failed: ") + e.what());
  }
  if (!result) return fail(result.error());
  int written = writeResult(args, *result);
  if (written == 0 && args.summary && !sweep && !args.out.empty() && args.out != "-") {
    std::cout << capture::summarize(*result);
  }
  return written;
}

}  // namespace tally::cli
