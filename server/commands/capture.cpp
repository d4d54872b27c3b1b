#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>

#include "capture/runner.hpp"
#include "capture/spec.hpp"
#include "capture/summary.hpp"
#include "sweeps/sweep.hpp"
#include "commands/commands.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/renderer.hpp"

namespace tally::cli {

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
  std::string dump = result->dump(1);
  if (args.out.empty() || args.out == "-") {
    std::cout << dump << "\n";
    return 0;
  }
  // Temp file + rename: a reader never sees a half-written result.
  std::string temp = args.out + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << dump << "\n";
    if (!out) return fail(args.out + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(temp, args.out, ec);
  if (ec) return fail(args.out + ": " + ec.message());
  if (args.summary && !sweep) std::cout << capture::summarize(*result);
  return 0;
}

}  // namespace tally::cli
