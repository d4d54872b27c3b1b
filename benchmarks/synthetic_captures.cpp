#include "synthetic_captures.hpp"

#include <unistd.h>
#include <zlib.h>

#include <chrono>
#include <ctime>
#include <fstream>
#include <sstream>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <random>

#include "renderers/renderer.hpp"

namespace tally::bench {

using nlohmann::json;

namespace {

constexpr int kCamerasPerScene = 10;  // "cameras": "auto" gives 10 per scene
constexpr int kScenesPerCapture = 2;
constexpr int kResolutionsPerCapture = 2;

// Devices a study might compare; ids as Vulkan reports them.
struct StandInDevice {
  const char* name;
  const char* vendorId;
  const char* deviceId;
  const char* driver;
};
constexpr StandInDevice kDevices[] = {
    {"NVIDIA H200", "0x10DE", "0x2335", "580.159.04"},
    {"NVIDIA GeForce RTX 4090", "0x10DE", "0x2684", "580.159.04"},
    {"AMD Radeon RX 7900 XTX", "0x1002", "0x744C", "Mesa 24.2.8"},
    {"llvmpipe (LLVM 15.0.6, 256 bits)", "0x10005", "0x0000", "Mesa 22.3.6 (LLVM 15.0.6)"},
};

struct Resolution {
  int width, height;
};
constexpr Resolution kResolutions[] = {{640, 360}, {1280, 720}, {1920, 1080}, {3840, 2160}};

// The procedural scenes with their parameters as a capture records them, and Sponza.
struct StandInScene {
  std::string name;
  json spec;    // as written in a capture spec
  json params;  // as the result's scene_params
};
const std::vector<StandInScene>& scenes() {
  static const std::vector<StandInScene> kScenes = {
      {"atrium", "atrium", {{"name", "atrium"}}},
      {"planes",
       {{"name", "planes"}, {"layers", 8}, {"order", "back-to-front"}, {"coverage", 1.0}},
       {{"name", "planes"}, {"layers", 8}, {"order", "back-to-front"}, {"coverage", 1.0}}},
      {"sky", {{"name", "sky"}, {"coverage", 0.5}}, {{"name", "sky"}, {"coverage", 0.5}}},
      {"Sponza", {{"gltf", "sponza/Sponza.gltf"}}, {{"gltf", "/srv/tally/scenes/sponza/Sponza.gltf"}}},
  };
  return kScenes;
}

Result<std::string> readMaybeGzipped(const std::string& path) {
  gzFile file = gzopen(path.c_str(), "rb");  // reads plain files unchanged
  if (!file) return makeError(path + ": cannot open");
  std::string text;
  char buffer[1 << 16];
  int n = 0;
  while ((n = gzread(file, buffer, sizeof buffer)) > 0) text.append(buffer, static_cast<size_t>(n));
  gzclose(file);
  if (n < 0) return makeError(path + ": cannot read (corrupt gzip?)");
  return text;
}

// The shader file names a capture hashes (result.shaders), with stand-in
// hashes: the object has the size of a real one, its values are not looked at.
json standInShaderHashes() {
  json out = json::object();
  std::error_code ec;
  auto dir = renderers::shaderDirectory();
  if (!dir) return out;
  for (const auto& entry : std::filesystem::directory_iterator(*dir, ec)) {
    if (!entry.is_regular_file()) continue;
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016zx", std::hash<std::string>{}(entry.path().filename().string()));
    out[entry.path().filename().string()] = hex;
  }
  return out;
}

// A PNG that is only a signature, IHDR and IEND: the store checks the header
// and keeps the bytes. Real screenshots would add their size to the database
// file but not to any route measured here (they live in their own table).
std::vector<uint8_t> standInPng(uint32_t width, uint32_t height) {
  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  for (uint32_t v : {width, height}) {
    for (int shift = 24; shift >= 0; shift -= 8) png.push_back(static_cast<uint8_t>(v >> shift));
  }
  png.insert(png.end(), {8, 6, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82});
  return png;
}

// Multiplies every number in `value` by `factor`, except frame counts ("n").
void scale(json& value, double factor) {
  if (value.is_number()) {
    value = value.get<double>() * factor;
  } else if (value.is_object()) {
    for (auto item : value.items()) {
      if (item.key() != "n") scale(item.value(), factor);
    }
  } else if (value.is_array()) {
    for (json& item : value) scale(item, factor);
  }
}

void scaleFields(json& object, std::initializer_list<const char*> keys, double factor) {
  for (const char* key : keys) {
    if (object.contains(key)) scale(object[key], factor);
  }
}

// Per-frame times (frame_ms_frames, gpu_ms_frames) for a template that
// predates them, as a capture stores them now: one a frame, spread over the
// time's own [min, max] around its median, in a fixed order per frame count.
json perFrameTimes(const json& object, const char* time, const char* spread) {
  double ms = object.value(time, 0.0);
  const json& s = object.contains(spread) && object[spread].is_object() ? object[spread] : json::object();
  double low = s.value("min", ms), high = s.value("max", ms);
  int frames = s.value("n", 20);
  json out = json::array();
  for (int f = 0; f < frames; ++f) {
    double t = frames > 1 ? static_cast<double>((f * 7) % frames) / (frames - 1) : 0.5;  // 0..1, shuffled
    out.push_back(low + (high - low) * t);
  }
  return out;
}

// A template sample for another camera, resolution and device: times and
// counts scaled by `factor` (pixels, and a jitter so that no two runs agree),
// with per-frame times where the template has none.
json makeSample(const json& source, int camera, double factor, const std::string& screenshot) {
  json sample = source;
  sample["camera"]["index"] = camera;
  sample["screenshot"] = screenshot;
  scaleFields(sample, {"frame_ms", "frame_ms_spread", "frame_ms_instrumented", "frame_ms_frames"}, factor);
  if (!sample.contains("frame_ms_frames")) sample["frame_ms_frames"] = perFrameTimes(sample, "frame_ms", "frame_ms_spread");
  for (json& pass : sample["passes"]) {
    scaleFields(pass,
                {"gpu_ms", "gpu_ms_spread", "gpu_ms_instrumented", "fragment_invocations",
                 "fragment_invocations_statistic", "gpu_ms_frames"},
                factor);
    if (!pass.contains("gpu_ms_frames")) pass["gpu_ms_frames"] = perFrameTimes(pass, "gpu_ms", "gpu_ms_spread");
    for (json& counter : pass["resources"]) scaleFields(counter, {"count", "bytes", "count_spread"}, factor);
  }
  return sample;
}

// The template run's resource list at another resolution: render targets
// resized, sized as their formats imply.
json resizeResources(const json& source, Resolution r) {
  json resources = source;
  int64_t targets = 0;
  for (json& resource : resources["list"]) {
    std::string kind = resource.value("kind", "");
    if (kind != "attachment" && kind != "depth") continue;
    int64_t bytes = int64_t{r.width} * r.height * resource.value("element_bytes", int64_t{0});
    resource["width"] = r.width;
    resource["height"] = r.height;
    resource["format_bytes"] = bytes;
    resource["allocation_bytes"] = bytes;
    targets += bytes;
  }
  resources["render_target_bytes"] = targets;
  return resources;
}

// What makeCapture reads from a template run.
bool usableRun(const json& run) {
  return run.is_object() && run.value("width", 0) > 0 && run.value("height", 0) > 0 &&
         run.value("resources", json()).is_object() && run["resources"].value("list", json()).is_array() &&
         run.value("samples", json()).is_array() && !run["samples"].empty();
}

json standInDevice(const json& source, const StandInDevice& d) {
  json device = source;
  device["name"] = d.name;
  device["vendorID"] = d.vendorId;
  device["deviceID"] = d.deviceId;
  device["driverInfo"] = d.driver;
  return device;
}

}  // namespace

Result<CaptureTemplate> loadTemplate(const std::string& path, const std::vector<std::string>& renderers) {
  auto text = readMaybeGzipped(path);
  if (!text) return makeError(text.error());
  json result = json::parse(*text, nullptr, false);
  if (result.is_discarded() || !result.is_object()) return makeError(path + ": not a JSON capture result");
  if (!result.contains("device") || !result["runs"].is_array())
    return makeError(path + ": a capture result needs device and runs");
  CaptureTemplate out;
  out.device = result["device"];
  for (const json& run : result["runs"]) {
    if (!usableRun(run)) continue;
    std::string renderer = run.value("renderer", "");
    if (!out.runs.count(renderer)) out.runs[renderer] = run;
  }
  for (const auto& name : renderers) {
    if (!out.runs.count(name)) return makeError(path + ": no run with samples for renderer '" + name + "'");
  }
  return out;
}

SyntheticCapture makeCapture(const CaptureTemplate& source, const std::vector<std::string>& renderers,
                             int index, int64_t maxSamples) {
  static const json kShaders = standInShaderHashes();
  constexpr int kDeviceCount = std::size(kDevices);
  const auto& allScenes = scenes();
  const int sceneCount = static_cast<int>(allScenes.size());
  // Consecutive captures walk devices, then resolution pairs, then scene pairs.
  const StandInDevice& device = kDevices[index % kDeviceCount];
  const int firstResolution = (index / kDeviceCount) % 2 * kResolutionsPerCapture;
  const int firstScene = index / (2 * kDeviceCount) % sceneCount;
  std::mt19937 random(static_cast<uint32_t>(index));
  std::uniform_real_distribution<double> jitter(0.9, 1.1);

  SyntheticCapture capture;
  json specScenes = json::array(), specResolutions = json::array();
  for (int s = 0; s < kScenesPerCapture; ++s)
    specScenes.push_back(allScenes[(firstScene + s) % sceneCount].spec);
  for (int r = 0; r < kResolutionsPerCapture; ++r) {
    const Resolution& res = kResolutions[firstResolution + r];
    specResolutions.push_back({res.width, res.height});
  }
  capture.spec = {{"renderers", renderers}, {"scenes", specScenes}, {"resolutions", specResolutions},
                  {"cameras", "auto"},      {"frames", 20},         {"counting", "exact"},
                  {"lights", 400}};
  json runs = json::array();
  // Scene, then resolution, then renderer: the order the capture runner uses.
  for (int s = 0; s < kScenesPerCapture && capture.samples < maxSamples; ++s) {
    const StandInScene& scene = allScenes[(firstScene + s) % sceneCount];
    for (int r = 0; r < kResolutionsPerCapture && capture.samples < maxSamples; ++r) {
      const Resolution& res = kResolutions[firstResolution + r];
      for (size_t k = 0; k < renderers.size() && capture.samples < maxSamples; ++k) {
        const json& model = source.runs.at(renderers[k]);
        const json& modelSamples = model.at("samples");
        double pixels = double(res.width) * res.height /
                        (model.at("width").get<double>() * model.at("height").get<double>());
        std::string prefix = renderers[k] + "_" + scene.name + "_" + std::to_string(res.width) + "x" +
                             std::to_string(res.height) + "_cam";
        json samples = json::array();
        for (int c = 0; c < kCamerasPerScene && capture.samples < maxSamples; ++c, ++capture.samples) {
          std::string shot = prefix + std::to_string(c) + ".png";
          samples.push_back(
              makeSample(modelSamples[c % modelSamples.size()], c, pixels * jitter(random), shot));
          capture.screenshots[shot] = standInPng(res.width, res.height);
        }
        runs.push_back({{"renderer", renderers[k]},
                        {"scene", scene.name},
                        {"scene_params", scene.params},
                        {"width", res.width},
                        {"height", res.height},
                        {"counting", "exact"},
                        {"lights", 400},
                        {"notes", model.value("notes", json::object())},
                        {"resources", resizeResources(model.at("resources"), res)},
                        {"samples", std::move(samples)}});
      }
    }
  }
  capture.result = {{"device", standInDevice(source.device, device)},
                    {"spec", capture.spec},
                    {"shaders", kShaders},
                    {"runs", std::move(runs)}};
  return capture;
}

namespace {

// This process's CPU time: the ingest's own thread and the one that reads
// a capture's passes beside it (store/piece_pipe.hpp); nothing else here
// runs during an ingest but the statistics keeper, which waits on its server.
double clientCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

// The writer's PostgreSQL backend, where it runs on this machine: its pid, else 0.
int64_t backendPid(store::Store& writer) {
  if (writer.connection().engine() != store::Engine::Postgres) return 0;
  try {
    store::Statement pid(writer.connection(), "SELECT pg_backend_pid()");
    int64_t found = pid.step() ? pid.getInt(0) : 0;
    pid.run();
    return std::filesystem::exists("/proc/" + std::to_string(found) + "/stat") ? found : 0;
  } catch (const std::exception&) {
    return 0;
  }
}

// A process's user and system CPU seconds from /proc/PID/stat; -1 when unreadable.
double processCpuSeconds(int64_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!pid || !std::getline(in, line)) return -1;
  size_t close = line.rfind(')');  // the command may hold spaces
  if (close == std::string::npos) return -1;
  std::istringstream fields(line.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int k = 3; k <= 15 && fields >> field; ++k) {
    if (k == 14 || k == 15) ticks += std::stod(field);  // utime, stime
  }
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

}  // namespace

Result<FillStats> fillDatabase(store::Store& writer, const CaptureTemplate& source,
                               const std::vector<std::string>& renderers, int64_t samples,
                               const std::function<void(int64_t)>& progress) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::duration d) { return std::chrono::duration<double>(d).count(); };
  FillStats stats;
  const int64_t backend = backendPid(writer);
  if (backend) stats.ingestServerCpuSeconds = 0;
  auto start = Clock::now();
  while (stats.samples < samples) {
    SyntheticCapture capture = makeCapture(source, renderers, stats.captures, samples - stats.samples);
    // The worker's path: a queued job, claimed (running), its result ingested, done.
    auto created = writer.jobs().create(capture.spec);
    if (!created) return makeError("creating a job: " + created.error());
    auto claimed = writer.jobs().claim(getpid());
    if (!claimed) return makeError("claiming a job: " + claimed.error());
    if (!*claimed || (*claimed)->id != created->job.id)
      return makeError("the database has other queued jobs; fill a fresh one");
    auto ingestStart = Clock::now();
    double clientCpu = clientCpuSeconds(), serverCpu = processCpuSeconds(backend);
    auto ingested = writer.runs().ingestCapture(created->job.id, capture.result, capture.screenshots);
    stats.ingestSeconds += seconds(Clock::now() - ingestStart);
    stats.ingestClientCpuSeconds += clientCpuSeconds() - clientCpu;
    if (backend && serverCpu >= 0) stats.ingestServerCpuSeconds += processCpuSeconds(backend) - serverCpu;
    if (!ingested)
      return makeError("ingesting capture " + std::to_string(stats.captures) + ": " + ingested.error());
    auto finished = writer.jobs().finish(created->job.id, store::JobStatus::Done);
    if (!finished) return makeError("finishing a job: " + finished.error());
    stats.captures += 1;
    stats.samples += capture.samples;
    progress(stats.samples);
  }
  auto settle = Clock::now();
  writer.runs().waitForStatistics();
  stats.statisticsWaitSeconds = seconds(Clock::now() - settle);
  stats.seconds = seconds(Clock::now() - start);
  return stats;
}

}  // namespace tally::bench
