#include "capture/application.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <system_error>

#include "capture/application_process.hpp"
#include "common/paths.hpp"
#include "common/child_process.hpp"

namespace tally::capture {
namespace fs = std::filesystem;
using nlohmann::json;
using detail::endingOf;
using detail::TempDir;
using detail::withStderr;
using detail::XServer;

namespace {

constexpr size_t kSteps = 3;  // started, output written, done

// What runs: the spec's program with its arguments, or gfxrecon-replay on the replay file.
Result<std::vector<std::string>> commandLineOf(const ApplicationSpec& spec) {
  std::vector<std::string> argv;
  if (spec.kind == ApplicationSpec::Kind::Replay) {
    const char* pathEnv = std::getenv("PATH");
    std::string replayer = findOnPath("gfxrecon-replay", pathEnv ? pathEnv : "");
    if (replayer.empty()) {
      return makeError("replay: gfxrecon-replay is not on $PATH (GFXReconstruct; Debian: apt install gfxreconstruct)");
    }
    // The window system: Xlib on the X server Tally starts, else a headless surface.
    argv = {replayer, "--wsi", spec.display == ApplicationSpec::Display::Xvfb ? "xlib" : "headless", spec.replayFile};
  } else {
    argv = spec.command;
    argv[0] = spec.program;
  }
  return argv;
}

// The child: the application as the user it runs as, with the layer's environment.
jobs::ChildOptions childOf(const ApplicationSpec& spec, const ApplicationOptions& options,
                           std::vector<std::string> argv, const std::vector<std::pair<std::string, std::string>>& env) {
  jobs::ChildOptions child;
  child.argv = std::move(argv);
  if (options.runAs) {
    child.runAs = options.runAs;
    child.environment.push_back("HOME=" + options.runAs->home);
    child.environment.push_back("USER=" + options.runAs->user);
    child.environment.push_back("LOGNAME=" + options.runAs->user);
  }
  for (const auto& [name, value] : env) child.environment.push_back(name + "=" + value);
  child.deadline = std::chrono::seconds(spec.timeoutSeconds);
  child.grace = options.exitGrace;
  child.stderrTailBytes = 8192;
  return child;
}

// The capture result once the application has ended: the layer's output read,
// or why there is none, with how the application ended.
Result<json> resultOf(const ApplicationSpec& spec, const jobs::ChildResult& ran, const fs::path& output,
                      const fs::path& layerDir) {
  const std::string ending = endingOf(ran);
  std::error_code ec;
  if (!fs::exists(output, ec)) {
    if (ran.end == jobs::ChildResult::End::TimedOut) {
      return makeError(withStderr("the application did not deliver " + std::to_string(spec.frames) + " frames" +
                                      (spec.skipFrames ? " after " + std::to_string(spec.skipFrames) + " skipped" : "") +
                                      " within " + spec.fieldPrefix() + "timeout_s (" +
                                      std::to_string(spec.timeoutSeconds) + " s) and was stopped",
                                  ran));
    }
    std::string message = "the application " + ending + " before the layer wrote its output";
    if (ran.end == jobs::ChildResult::End::Exited && ran.exitCode == 0) {
      message += " (it ran fewer than " + std::to_string(spec.skipFrames + spec.frames) +
                 " frames, or the layer did not load: manifest " + (layerDir / kLayerManifest).string() + ")";
    }
    return makeError(withStderr(message, ran));
  }
  std::ifstream in(output, std::ios::binary);
  std::string textOut((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  json layerOutput = json::parse(textOut, nullptr, false);
  if (layerOutput.is_discarded() || !layerOutput.is_object()) {
    return makeError("the layer's output is not a valid JSON object (" + std::to_string(textOut.size()) +
                     " bytes); the application " + ending);
  }
  auto result = applicationResult(spec, layerOutput);
  if (!result) {
    // Fewer frames than asked: say how the application ended too.
    return makeError(withStderr(result.error() + "; the application " + ending, ran));
  }
  (*result)["runs"][0]["notes"]["application_exit"] = ending;
  return result;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> layerEnvironment(const ApplicationSpec& spec, const fs::path& layerDir,
                                                                  const fs::path& output) {
  std::vector<std::pair<std::string, std::string>> env = {
      {"VK_ADD_LAYER_PATH", layerDir.string()},
      {"VK_INSTANCE_LAYERS", kLayerName},
      // The loader's newer filter (1.3.234+); harmless on older loaders.
      {"VK_LOADER_LAYERS_ENABLE", kLayerName},
      {"TALLY_LAYER_OUTPUT", output.string()},
      {"TALLY_LAYER_FRAMES", std::to_string(spec.frames)},
      {"TALLY_LAYER_SKIP_FRAMES", std::to_string(spec.skipFrames)},
      {"TALLY_LAYER_FRAME_SUBMITS", std::to_string(spec.frameSubmits)},
      {"TALLY_LAYER_COUNTING", spec.counting},
      {"TALLY_LAYER_SITES", spec.sites ? "1" : "0"},
      {"TALLY_LAYER_DRAWS", spec.draws || spec.sites ? "1" : "0"},
      // Every stored frame keeps its statistic, the check on its counts.
      {"TALLY_LAYER_STATISTICS_FRAMES", "all"},
  };
  env.insert(env.end(), spec.env.begin(), spec.env.end());
  return env;
}

Result<json> runApplication(const ApplicationSpec& spec, const ApplicationOptions& options) {
  const std::string label = applicationRunName(spec);
  auto report = [&](size_t done, const std::string& current) {
    if (options.progress) options.progress(Progress{done, kSteps, label + ": " + current});
  };
  auto layerDir = layerDirectory();
  if (!layerDir) return makeError(layerDir.error());

  Result<std::vector<std::string>> argv = commandLineOf(spec);
  if (!argv) return makeError(argv.error());

  auto temp = TempDir::make(options.tempRoot);
  if (!temp) return makeError(temp.error());
  // The layer, inside the application, writes its output here.
  if (options.runAs && chown(temp->path.c_str(), options.runAs->uid, options.runAs->gid) != 0) {
    return makeError("cannot give " + temp->path.string() + " to user " + options.runAs->user + ": " +
                     std::strerror(errno));
  }
  const fs::path output = temp->path / "layer-output.json";

  std::unique_ptr<XServer> xserver;
  std::vector<std::pair<std::string, std::string>> env = layerEnvironment(spec, *layerDir, output);
  if (spec.display == ApplicationSpec::Display::Xvfb) {
    report(0, "starting Xvfb");
    auto started = XServer::start(temp->path / "xvfb.log");
    if (!started) return makeError("display \"xvfb\": " + started.error());
    xserver = std::move(started).value();
    env.emplace_back("DISPLAY", ":" + std::to_string(xserver->display()));
  }

  jobs::ChildOptions child = childOf(spec, options, std::move(*argv), env);
  const auto started = std::chrono::steady_clock::now();
  auto lastReport = started;
  std::optional<std::chrono::steady_clock::time_point> outputAt;
  const std::string waiting = "waiting for " + std::to_string(spec.frames) + " frames" +
                              (spec.skipFrames ? " after " + std::to_string(spec.skipFrames) + " skipped" : "");
  // Polled about every 200 ms while it runs: the output's arrival, and a line every 10 s till then.
  child.shouldTerminate = [&] {
    auto now = std::chrono::steady_clock::now();
    std::error_code ec;
    if (!outputAt && fs::exists(output, ec)) {
      outputAt = now;
      report(2, "the layer wrote its output; waiting for the application to exit");
    }
    if (!outputAt && now - lastReport >= std::chrono::seconds(10)) {
      lastReport = now;
      report(1, waiting + " (" + std::to_string(std::chrono::duration_cast<std::chrono::seconds>(now - started).count()) + " s)");
    }
    return outputAt && now - *outputAt >= options.exitGrace;
  };
  report(1, waiting);
  auto ran = jobs::runChild(child);
  xserver.reset();  // stopped before anything else, whatever happened
  if (!ran) return makeError(ran.error());
  auto result = resultOf(spec, *ran, output, *layerDir);
  if (!result) return result;
  report(kSteps, "done, " + std::to_string((*result)["runs"][0]["samples"].size()) + " frames");
  return result;
}

}  // namespace tally::capture
