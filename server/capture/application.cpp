#include "capture/application.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "common/json_fields.hpp"
#include "common/paths.hpp"
#include "common/version.hpp"
#include "common/child_process.hpp"

namespace tally::capture {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr size_t kSteps = 3;            // started, output written, done
constexpr size_t kMaxSceneChars = 120;  // the run's scene: the command line, shortened

// ---- the layer's output ---------------------------------------------------------------

struct Malformed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void malformed(const std::string& path, const std::string& what) { throw Malformed(path + ": " + what); }

std::string at(const std::string& path, const char* key) { return path.empty() ? key : path + "." + key; }

// Members of the layer's output: a fault throws Malformed naming the path.
using json_fields::find;
constexpr json_fields::Members kMembers{[](const Error& error) { throw Malformed(error.text()); }};

std::string item(const std::string& path, const char* key, size_t i) {
  return at(path, key) + "[" + std::to_string(i) + "]";
}

// One line of a pass: a resource, an access, its count and bytes per frame.
json lineOf(const json& line, const std::string& path) {
  if (!line.is_object()) malformed(path, "must be an object");
  std::string access = kMembers.text(line, "access", path);
  if (access != "read" && access != "write") malformed(at(path, "access"), "must be \"read\" or \"write\", got \"" + access + "\"");
  double count = kMembers.number(line, "count", path), bytes = kMembers.number(line, "bytes", path);
  if (count < 0) malformed(at(path, "count"), "must not be negative");
  if (bytes < 0) malformed(at(path, "bytes"), "must not be negative");
  json out = {{"name", kMembers.text(line, "name", path)},
              {"kind", kMembers.optText(line, "kind", path).value_or("")},
              {"format", kMembers.optText(line, "format", path).value_or("")},
              {"access", access},
              {"count", count},
              {"bytes", bytes},
              {"source", kMembers.optText(line, "source", path).value_or("counter")}};
  return out;
}

// A pass as the capture result has it. gpu_ms is -1 where the device has no
// timestamps (0 here, and the run says so); a statistic of -1 was not queried
// (left out).
json passOf(const json& pass, const std::string& path, bool& untimed) {
  if (!pass.is_object()) malformed(path, "must be an object");
  double gpuMs = kMembers.number(pass, "gpu_ms", path);
  if (gpuMs < 0) {
    untimed = true;
    gpuMs = 0;
  }
  json out = {{"name", kMembers.text(pass, "name", path)}, {"gpu_ms", gpuMs}};
  const auto draws = kMembers.optInteger(pass, "draws", path),
             dispatches = kMembers.optInteger(pass, "dispatches", path);
  if (draws) out["draws"] = *draws;
  if (dispatches) out["dispatches"] = *dispatches;
  for (const char* key : {"fragment_invocations", "vertex_invocations"}) {
    if (auto v = kMembers.optNumber(pass, key, path)) out[key] = *v;
  }
  if (auto v = kMembers.optNumber(pass, "fragment_invocations_statistic", path); v && *v >= 0)
    out["fragment_invocations_statistic"] = *v;
  // Compute figures belong to passes that dispatch (docs/result-schema.md).
  auto compute = kMembers.optNumber(pass, "compute_invocations", path);
  if (compute && (dispatches.value_or(0) > 0 || *compute > 0)) {
    out["compute_invocations"] = *compute;
    if (auto v = kMembers.optNumber(pass, "compute_invocations_statistic", path); v && *v >= 0) {
      out["compute_invocations_statistic"] = *v;
    }
  }
  json lines = json::array();
  double bytes = 0;
  const json& resources = kMembers.array(pass, "resources", path);
  for (size_t i = 0; i < resources.size(); ++i) {
    lines.push_back(lineOf(resources[i], item(path, "resources", i)));
    bytes += lines.back()["bytes"].get<double>();
  }
  out["resources"] = std::move(lines);
  out["bytes"] = bytes;
  return out;
}

// The layer's resource list entry, with format_bytes where the image's size is known.
json resourceOf(const json& resource, const std::string& path) {
  if (!resource.is_object()) malformed(path, "must be an object");
  json out = {{"name", kMembers.text(resource, "name", path)},
              {"kind", kMembers.text(resource, "kind", path)},
              {"format", kMembers.optText(resource, "format", path).value_or("")}};
  for (const char* key : {"element_bytes", "width", "height", "samples", "allocation_bytes"}) {
    if (auto v = kMembers.optInteger(resource, key, path)) {
      if (*v < 0) malformed(at(path, key), "must not be negative");
      out[key] = *v;
    }
  }
  const int64_t element = out.value("element_bytes", int64_t{0}), width = out.value("width", int64_t{0}),
                height = out.value("height", int64_t{0}), samples = out.value("samples", int64_t{1});
  if (element > 0 && width > 0 && height > 0) out["format_bytes"] = element * width * height * std::max<int64_t>(samples, 1);
  out["usage"] = kMembers.optText(resource, "usage", path).value_or("");
  out["memory"] = kMembers.optText(resource, "memory", path).value_or("");
  return out;
}

// The frame's size: the layer's extent, else the largest image, else 1x1 (noted).
std::pair<int64_t, int64_t> extentOf(const json& output, const json& resources, json& notes) {
  int64_t width = 0, height = 0;
  if (const json* extent = find(output, "extent")) {
    if (!extent->is_array() || extent->size() != 2 || !(*extent)[0].is_number_integer() || !(*extent)[1].is_number_integer()) {
      malformed("extent", "must be [width, height], got " + extent->dump());
    }
    width = (*extent)[0].get<int64_t>();
    height = (*extent)[1].get<int64_t>();
  }
  if (width < 1 || height < 1 || width > kMaxDimension || height > kMaxDimension) {
    width = height = 0;
    for (const auto& r : resources) {
      int64_t w = r.value("width", int64_t{0}), h = r.value("height", int64_t{0});
      if (w >= 1 && h >= 1 && w <= kMaxDimension && h <= kMaxDimension && w * h > width * height) {
        width = w;
        height = h;
      }
    }
    notes["extent"] = width > 0 ? "the layer reported none: the largest image's size stands in"
                                : "the layer reported none and there is no image: 1x1 stands in";
    if (width == 0) width = height = 1;
  }
  return {width, height};
}

// One sample a frame: the camera's place holds the frame.
json samplesOf(const json& frames, const ApplicationSpec& spec, bool& untimed) {
  json samples = json::array();
  for (size_t f = 0; f < frames.size(); ++f) {
    const std::string path = item("", "frames", f);
    const json& frame = frames[f];
    if (!frame.is_object()) malformed(path, "must be an object");
    const int64_t index =
        kMembers.optInteger(frame, "index", path).value_or(static_cast<int64_t>(spec.skipFrames + f));
    json passes = json::array();
    double frameMs = 0, bytes = 0;
    const json& passList = kMembers.array(frame, "passes", path);
    for (size_t p = 0; p < passList.size(); ++p) {
      passes.push_back(passOf(passList[p], item(path, "passes", p), untimed));
      frameMs += passes.back()["gpu_ms"].get<double>();
      bytes += passes.back()["bytes"].get<double>();
    }
    // The camera's place holds the frame: its label names it, the rest is what the layer saw.
    json camera = {
        {"label", "frame " + std::to_string(index)}, {"index", static_cast<int64_t>(f)}, {"frame", index}};
    if (auto submissions = kMembers.optInteger(frame, "submissions", path))
      camera["submissions"] = *submissions;
    json sample = {{"camera", std::move(camera)}, {"sky_fraction", -1}, {"frames", 1}, {"frame_ms", frameMs}};
    if (auto host = kMembers.optNumber(frame, "frame_ms", path)) sample["frame_ms_layer"] = *host;
    sample["passes"] = std::move(passes);
    sample["bytes"] = bytes;
    sample["extras"] = json::object();
    samples.push_back(std::move(sample));
  }
  return samples;
}

// Shaders the layer could not instrument: their pipelines ran uncounted.
json uninstrumentedOf(const json& output) {
  json uninstrumented = json::array();
  const json& shaders = kMembers.array(output, "shaders", "");
  for (size_t i = 0; i < shaders.size(); ++i) {
    const std::string path = item("", "shaders", i);
    if (!shaders[i].is_object()) malformed(path, "must be an object");
    const json* instrumented = find(shaders[i], "instrumented");
    if (!instrumented || *instrumented != false) continue;
    uninstrumented.push_back({{"name", kMembers.optText(shaders[i], "name", path).value_or("")},
                              {"stage", kMembers.optText(shaders[i], "stage", path).value_or("")},
                              {"reason", kMembers.optText(shaders[i], "reason", path).value_or("")}});
  }
  return uninstrumented;
}

std::string basename(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  return name.empty() ? path : name;
}

// The command line as one string: arguments with spaces quoted, shortened.
std::string sceneOf(const ApplicationSpec& spec) {
  if (spec.kind == ApplicationSpec::Kind::Replay) {
    const std::string& file = spec.replayFile;
    return file.size() <= kMaxSceneChars ? file : "..." + file.substr(file.size() - (kMaxSceneChars - 3));
  }
  std::string line;
  for (const auto& arg : spec.command) {
    if (!line.empty()) line += ' ';
    line += arg.find_first_of(" \t\"'") == std::string::npos && !arg.empty() ? arg : json(arg).dump();
  }
  return line.size() <= kMaxSceneChars ? line : line.substr(0, kMaxSceneChars - 3) + "...";
}

// The source of the run, as notes.source: what was run and how.
json sourceOf(const ApplicationSpec& spec) {
  json env = json::object();
  for (const auto& [name, value] : spec.env) env[name] = value;
  json source = {{"kind", spec.kind == ApplicationSpec::Kind::Replay ? "replay" : "application"}};
  if (spec.kind == ApplicationSpec::Kind::Replay) {
    source["replay"] = spec.replayFile;
  } else {
    source["command"] = spec.command;
    source["program"] = spec.program;
    if (!spec.name.empty()) source["name"] = spec.name;
  }
  source["frames"] = spec.frames;
  source["skip_frames"] = spec.skipFrames;
  source["frame_submits"] = spec.frameSubmits;
  source["display"] = spec.display == ApplicationSpec::Display::Xvfb ? "xvfb" : "none";
  source["env"] = std::move(env);
  return source;
}

// ---- processes ------------------------------------------------------------------------

// The last `count` non-empty lines of a stderr tail, joined by " | ", each
// shortened: one line for an error message.
std::string lastLines(const std::string& tail, size_t count = 3) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < tail.size()) {
    size_t end = tail.find('\n', start);
    std::string line = tail.substr(start, end == std::string::npos ? std::string::npos : end - start);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    if (!line.empty()) lines.push_back(line.size() > 200 ? line.substr(0, 197) + "..." : line);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  std::string out;
  for (size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i) {
    out += (out.empty() ? "" : " | ") + lines[i];
  }
  return out;
}

// A temporary folder of the capture's own (the layer's output, Xvfb's log), removed at the end.
struct TempDir {
  fs::path path;
  static Result<TempDir> make(fs::path root) {
    std::error_code ec;
    if (root.empty()) root = fs::temp_directory_path(ec);
    if (ec || root.empty()) root = "/tmp";
    std::string pattern = (root / "tally-app-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) return makeError("cannot create a folder under " + root.string() + ": " + std::strerror(errno));
    return TempDir{pattern};
  }
  TempDir(fs::path p) : path(std::move(p)) {}  // NOLINT(google-explicit-constructor)
  TempDir(TempDir&& other) noexcept : path(std::exchange(other.path, {})) {}
  TempDir(const TempDir&) = delete;
  ~TempDir() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
};

std::string readTail(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text.size() > 4096 ? text.substr(text.size() - 4096) : text;
}

// An X server of the capture's own: Xvfb on the first free display
// (-displayfd), stopped (SIGTERM, then SIGKILL) when this is destroyed. It
// dies with tallyd even on kill -9 (PR_SET_PDEATHSIG) and shares tallyd's
// process group, so a cancelled job's kill reaches it too.
class XServer {
 public:
  static Result<std::unique_ptr<XServer>> start(const fs::path& log) {
    const char* pathEnv = std::getenv("PATH");
    std::string program = findOnPath("Xvfb", pathEnv ? pathEnv : "");
    if (program.empty()) return makeError("Xvfb is not on $PATH (Debian: apt install xvfb)");
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) return makeError(std::string("pipe: ") + std::strerror(errno));
    constexpr int kDisplayFd = 3;
    std::string displayFd = std::to_string(kDisplayFd), logPath = log.string();
    std::vector<std::string> args = {program, "-displayfd", displayFd, "-screen", "0", "1280x1024x24", "-nolisten", "tcp"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    // In tallyd's process group (see above); its stdout and stderr go to the log.
    auto spawned = jobs::spawnProcess(argv, {logPath, -1, false, fds[1], kDisplayFd, nullptr});
    if (!spawned) {
      close(fds[0]);
      close(fds[1]);
      return makeError("Xvfb: " + spawned.error());
    }
    const pid_t pid = *spawned;
    close(fds[1]);
    auto server = std::unique_ptr<XServer>(new XServer(pid));
    // The display number, one line, once the server accepts connections.
    std::string number;
    auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    bool ended = false;
    while (!ended && number.find('\n') == std::string::npos) {
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      pollfd p{fds[0], POLLIN, 0};
      int ready = poll(&p, 1, static_cast<int>(left.count()));
      if (ready < 0 && errno == EINTR) continue;
      if (ready <= 0) break;
      char buffer[64];
      ssize_t n = read(fds[0], buffer, sizeof buffer);
      if (n <= 0) {
        ended = true;
      } else {
        number.append(buffer, static_cast<size_t>(n));
      }
    }
    close(fds[0]);
    size_t used = 0;
    int display = -1;
    try {
      display = std::stoi(number, &used);
    } catch (const std::exception&) {
      display = -1;
    }
    if (display < 0) {
      server.reset();  // stops it, if it still runs
      std::string why = lastLines(readTail(log), 2);
      return makeError(std::string(ended ? "Xvfb exited" : "Xvfb gave no display within 15 s") +
                       (why.empty() ? "" : ": " + why));
    }
    server->display_ = display;
    return server;
  }

  ~XServer() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() >= deadline) {
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  XServer(const XServer&) = delete;
  XServer& operator=(const XServer&) = delete;

  int display() const { return display_; }

 private:
  explicit XServer(pid_t pid) : pid_(pid) {}
  pid_t pid_ = 0;
  int display_ = -1;
};

// How the application ended, as what "the application ..." did: "exited with
// status 0", "was killed by signal 11 (SIGSEGV)", "was stopped by tallyd
// (SIGTERM) once the output was written".
std::string endingOf(const jobs::ChildResult& r) {
  using End = jobs::ChildResult::End;
  if (r.end == End::TimedOut) return "timed out after " + std::to_string(r.elapsed.count() / 1000) + " s";
  if (r.terminated) {
    if (r.end == End::Exited) return "exited with status " + std::to_string(r.exitCode) + " when asked to stop (SIGTERM)";
    if (r.signal == SIGKILL) return "was killed by tallyd (SIGKILL): it did not exit on SIGTERM";
    return "was stopped by tallyd (SIGTERM) once the output was written";
  }
  if (r.end == End::Exited) return "exited with status " + std::to_string(r.exitCode);
  jobs::ChildResult quiet = r;
  quiet.stderrTail.clear();
  return "was " + quiet.reason();  // "was killed by signal 11 (SIGSEGV)"
}

std::string withStderr(std::string message, const jobs::ChildResult& r) {
  std::string tail = lastLines(r.stderrTail);
  return tail.empty() ? message + "; it wrote nothing on stderr" : message + "; its stderr ended: " + tail;
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
      // Every stored frame keeps its statistic, the check on its counts.
      {"TALLY_LAYER_STATISTICS_FRAMES", "all"},
  };
  env.insert(env.end(), spec.env.begin(), spec.env.end());
  return env;
}

std::string applicationRunName(const ApplicationSpec& spec, const json& layerOutput) {
  if (spec.kind == ApplicationSpec::Kind::Replay) return "replay:" + basename(spec.replayFile);
  if (!spec.name.empty()) return "app:" + spec.name;
  if (layerOutput.is_object()) {
    const json* app = find(layerOutput, "application");
    const json* name = app && app->is_object() ? find(*app, "name") : nullptr;
    if (name && name->is_string() && !name->get<std::string>().empty()) return "app:" + name->get<std::string>();
  }
  return "app:" + basename(spec.command.empty() ? spec.program : spec.command[0]);
}

Result<json> applicationResult(const ApplicationSpec& spec, const json& output) {
  try {
    if (!output.is_object()) malformed("output", "must be a JSON object");
    // The device, as the layer saw it: the store keys devices on name, vendor, id, driver and API version.
    const json& device = kMembers.object(output, "device", "");
    if (device.empty()) malformed("device", "missing");
    kMembers.text(device, "name", "device");
    const json& layer = kMembers.object(output, "layer", "");
    const json& application = kMembers.object(output, "application", "");
    // Nothing counted: the layer could not count on this device, or every
    // pipeline layout of the application uses every descriptor set (the
    // application ran unchanged, but there is nothing to store).
    if (find(layer, "counting_enabled") && layer["counting_enabled"] == false) {
      return makeError("the layer counted nothing: " +
                       (find(layer, "not_counting") && layer["not_counting"].is_string()
                            ? layer["not_counting"].get<std::string>()
                            : std::string("counting was off")));
    }
    if (find(layer, "pipelines_counted") && layer["pipelines_counted"] == 0 &&
        find(layer, "layouts_refused") && layer["layouts_refused"].is_number_unsigned() &&
        layer["layouts_refused"].get<uint64_t>() > 0) {
      return makeError("the layer counted nothing: every pipeline of the application has a layout that uses every "
                       "descriptor set the device allows (" +
                       std::to_string(layer["layouts_refused"].get<uint64_t>()) +
                       " layouts refused; the layer needs the last set for its counters), so its pipelines ran "
                       "unchanged and uncounted");
    }
    const json& frames = kMembers.array(output, "frames", "");
    if (frames.empty()) malformed("frames", "missing or empty: no frame was read back");
    const bool complete = find(output, "complete") ? output["complete"] == true : true;
    if (frames.size() < spec.frames) {
      return makeError("only " + std::to_string(frames.size()) + " of the " + std::to_string(spec.frames) +
                       " frames asked for arrived" +
                       (complete ? "" : " (the layer's output says complete: false: the application tore its device down first)"));
    }

    // Resources, and the render targets' total as a renderer's run has it.
    json resources = json::array();
    std::optional<int64_t> renderTargets;
    const json& resourceList = kMembers.array(output, "resources", "");
    for (size_t i = 0; i < resourceList.size(); ++i) {
      json r = resourceOf(resourceList[i], item("", "resources", i));
      const std::string kind = r["kind"].get<std::string>();
      if ((kind == "attachment" || kind == "depth") && r.contains("allocation_bytes")) {
        renderTargets = renderTargets.value_or(0) + r["allocation_bytes"].get<int64_t>();
      }
      resources.push_back(std::move(r));
    }

    json notes = json::object();
    const auto [width, height] = extentOf(output, resources, notes);

    bool untimed = false;
    json samples = samplesOf(frames, spec, untimed);

    json uninstrumented = uninstrumentedOf(output);
    json layerNotes = json::array();
    const json& noteList = kMembers.array(output, "notes", "");
    for (size_t i = 0; i < noteList.size(); ++i) {
      if (!noteList[i].is_string()) malformed(item("", "notes", i), "must be a string");
      layerNotes.push_back(noteList[i]);
    }

    notes["timing"] = "instrumented";
    if (untimed) notes["gpu_time"] = "unavailable: the device has no timestamp queries (gpu_ms and frame_ms are 0)";
    notes["layer"] = layer;
    notes["uninstrumented_shaders"] = std::move(uninstrumented);
    if (!layerNotes.empty()) notes["layer_notes"] = std::move(layerNotes);
    if (!complete) notes["layer_complete"] = false;
    notes["source"] = sourceOf(spec);
    if (!application.empty()) notes["application"] = application;

    const std::string name = applicationRunName(spec, output);
    json run = {
        {"renderer", name},
        {"variant", name},
        {"options", json::object()},
        {"scene", sceneOf(spec)},
        {"scene_params", spec.kind == ApplicationSpec::Kind::Replay ? json{{"replay", spec.replayFile}}
                                                                    : json{{"command", spec.command}}},
        {"width", width},
        {"height", height},
        {"counting", kMembers.optText(layer, "counting", "layer").value_or(spec.counting)},
        {"lights", 0},
        {"notes", std::move(notes)},
        {"resources",
         {{"render_target_bytes", renderTargets ? json(*renderTargets) : json(nullptr)},
          {"list", std::move(resources)}}},
        {"samples", std::move(samples)}};
    return json{{"device", device},
                {"tally", {{"version", std::string(version())}, {"commit", std::string(gitCommit())}}},
                {"spec", spec.source},
                {"shaders", json::object()},
                {"runs", json::array({std::move(run)})}};
  } catch (const Malformed& e) {
    return makeError(std::string("the layer's output is malformed: ") + e.what());
  } catch (const json::exception& e) {
    return makeError(std::string("the layer's output is malformed: ") + e.what());
  }
}

Result<json> runApplication(const ApplicationSpec& spec, const ApplicationOptions& options) {
  const std::string label = applicationRunName(spec);
  auto report = [&](size_t done, const std::string& current) {
    if (options.progress) options.progress(Progress{done, kSteps, label + ": " + current});
  };
  auto layerDir = layerDirectory();
  if (!layerDir) return makeError(layerDir.error());

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

  jobs::ChildOptions child;
  child.argv = argv;
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
  const std::string ending = endingOf(*ran);

  std::error_code ec;
  if (!fs::exists(output, ec)) {
    if (ran->end == jobs::ChildResult::End::TimedOut) {
      return makeError(withStderr("the application did not deliver " + std::to_string(spec.frames) + " frames" +
                                      (spec.skipFrames ? " after " + std::to_string(spec.skipFrames) + " skipped" : "") +
                                      " within " + spec.fieldPrefix() + "timeout_s (" +
                                      std::to_string(spec.timeoutSeconds) + " s) and was stopped",
                                  *ran));
    }
    std::string message = "the application " + ending + " before the layer wrote its output";
    if (ran->end == jobs::ChildResult::End::Exited && ran->exitCode == 0) {
      message += " (it ran fewer than " + std::to_string(spec.skipFrames + spec.frames) +
                 " frames, or the layer did not load: manifest " + (*layerDir / kLayerManifest).string() + ")";
    }
    return makeError(withStderr(message, *ran));
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
    return makeError(withStderr(result.error() + "; the application " + ending, *ran));
  }
  (*result)["runs"][0]["notes"]["application_exit"] = ending;
  report(kSteps, "done, " + std::to_string((*result)["runs"][0]["samples"].size()) + " frames");
  return result;
}

}  // namespace tally::capture
