// The layer's output: what it counted, frame by frame, with the device, the
// application, the resources it saw and its notes (docs/layer.md, "Running an
// application under the layer by hand"). readback.cpp writes it.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "names.hpp"
#include "shader_objects.hpp"
#include "state.hpp"

namespace tally::layer {

namespace {

// The window's frames that are read whole, each pass with its lines; `used`
// gets every resource a line names.
nlohmann::json framesJson(const DeviceState& dev, std::map<std::string, const Resource*>& used) {
  using nlohmann::json;
  json frames = json::array();
  for (const auto& [index, frame] : dev.frames) {
    if (!frame.done()) continue;
    // Later subpasses join their render pass instance's pass; passes that share a label stay apart, numbered.
    const std::vector<PassRecord> merged = distinctPasses(frame.passes);
    json passes = json::array();
    double frameMs = 0;
    for (const auto& p : merged) {
      json resources = json::array();
      for (const auto& [key, line] : p.lines) {
        const auto& [name, write, source] = key;
        resources.push_back({{"name", name},
                             {"kind", line.kind},
                             {"format", line.format},
                             {"access", write ? "write" : "read"},
                             {"count", line.count},
                             {"bytes", line.bytes},
                             {"source", source}});
        used[name] = nullptr;
      }
      frameMs += p.timed ? p.gpuMs : 0;
      json sites = json::array();
      for (const auto& [key, s] : p.sites) {
        sites.push_back(spirv::countedSiteJson(s.site, std::get<2>(key), std::get<3>(key), s.kind, double(s.count),
                                               double(s.bytes)));
      }
      passes.push_back({{"name", p.name},
                        {"gpu_ms", p.timed ? p.gpuMs : -1.0},
                        {"draws", p.draws},
                        {"dispatches", p.dispatches},
                        {"fragment_invocations", p.fragmentInvocations},
                        {"fragment_invocations_statistic", p.fragmentStatistic},
                        {"vertex_invocations", p.vertexInvocations},
                        {"vertex_invocations_statistic", p.vertexStatistic},
                        {"compute_invocations", p.computeInvocations},
                        {"compute_invocations_statistic", p.computeStatistic},
                        {"resources", std::move(resources)}});
      if (!sites.empty()) passes.back()["sites"] = std::move(sites);
      // "draws" stays the number of draw commands; the per-draw list is apart.
      if (dev.config.draws && p.draws > 0) passes.back()["draw_list"] = drawListJson(p);
      if (nlohmann::json rest = drawsRestJson(p); !rest.is_null()) passes.back()["draws_rest"] = std::move(rest);
    }
    frames.push_back({{"index", index}, {"submissions", frame.submissions}, {"frame_ms", frameMs}, {"passes", passes}});
  }
  return frames;
}

}  // namespace

nlohmann::json outputJson(DeviceState& dev, bool complete) {
  using nlohmann::json;
  char vendor[16];
  std::snprintf(vendor, sizeof vendor, "0x%X", dev.properties.vendorID);
  char deviceId[16];
  std::snprintf(deviceId, sizeof deviceId, "0x%X", dev.properties.deviceID);
  const uint32_t api = dev.properties.apiVersion;
  std::string executable;
  {
    std::error_code ec;
    executable = std::filesystem::read_symlink("/proc/self/exe", ec).string();
  }
  std::string appName = dev.instance->applicationName;
  if (appName.empty()) appName = std::filesystem::path(executable).filename().string();
  bool timestamps = false;
  for (const auto& f : dev.families) timestamps = timestamps || f.timestampValidBits > 0;
  json out = {
      {"complete", complete},
      {"layer",
       {{"name", "VK_LAYER_TALLY_counters"},
        {"version", "0.1.0"},
        {"counting", dev.config.counts ? spirv::toString(dev.config.mode) : "off"},
        {"sites", dev.config.sites},
        {"draws", dev.config.draws},
        {"timing", dev.config.statistics ? "all" : dev.config.timestamps ? "timestamps" : "none"},
        {"counter_bits", dev.int64Atomics ? 64 : 32},
        {"statistics_frames", dev.config.statisticsFrames == UINT32_MAX ? json("all") : json(dev.config.statisticsFrames)},
        {"descriptor_set", dev.counterSet},
        {"frame_delimiter",
         dev.config.frameSubmits == 0 ? std::string("present") : "submits:" + std::to_string(dev.config.frameSubmits)},
        {"skip_frames", dev.config.skipFrames},
        {"counting_enabled", dev.counting},
        {"pipelines", dev.pipelinesCreated},
        {"pipelines_counted", dev.pipelinesCounted},
        {"pipeline_libraries", dev.librariesCreated},
        {"pipelines_linked", dev.pipelinesLinked},
        {"shader_objects", dev.shaderObjects ? dev.shaderObjects->created : 0},
        {"shader_objects_counted", dev.shaderObjects ? dev.shaderObjects->counted : 0},
        {"layouts_refused", dev.layoutsRefused},
        {"spirv_validation", spirv::describe(dev.instrumentOptions.target)},
        {"not_counting", dev.notCounting},
        {"frames_wanted", dev.config.frames},
        {"frames_counted", framesCounted(dev)},
        {"frames_left_out", dev.framesLeftOut},
        {"readbacks", dev.nextHarvest},
        {"readbacks_riding", dev.readbacksRiding},
        {"readback_waits", dev.readbackWaits},
        {"query_pools", dev.queryPoolsCreated},
        {"pipeline_creation_ms",
         {{"application", dev.pipelineMsApplication}, {"instrumented", dev.pipelineMsInstrumented}}}}},
      {"application", {{"name", appName}, {"engine", dev.instance->engineName}, {"executable", executable}}},
      {"device",
       {{"name", dev.properties.deviceName},
        {"index", dev.index},
        {"vendorID", vendor},
        {"deviceID", deviceId},
        {"driverInfo", dev.driverInfo},
        {"apiVersion", std::to_string(VK_API_VERSION_MAJOR(api)) + "." + std::to_string(VK_API_VERSION_MINOR(api)) +
                           "." + std::to_string(VK_API_VERSION_PATCH(api))},
        {"timestamps", timestamps},
        {"pipeline_statistics", dev.statistics}}},
  };
  // The extent: the swapchain's, else the largest colour attachment seen.
  VkExtent2D extent = dev.extent;
  std::map<std::string, const Resource*> used;
  json frames = framesJson(dev, used);
  json resources = json::array();
  std::set<std::string> listed;
  for (const auto& [handle, r] : dev.resources) {
    const std::string name = r.displayName();
    if (!used.count(name) || !listed.insert(name).second) continue;
    if (extent.width == 0 && r.kind == Kind::Attachment && uint64_t(r.width) * r.height > 0) {
      extent = {r.width, r.height};
    }
    resources.push_back({{"name", name},
                         {"kind", toString(r.kind)},
                         {"format", r.image ? formatName(r.format) : ""},
                         {"element_bytes", r.image ? formatBytes(r.format) : 0},
                         {"width", r.width},
                         {"height", r.height},
                         {"samples", r.samples},
                         {"allocation_bytes", r.size},
                         {"usage", r.usage},
                         {"memory", ""}});
  }
  out["extent"] = {extent.width, extent.height};
  out["resources"] = std::move(resources);
  out["shaders"] = dev.shaderReports;
  std::vector<std::string> notes(dev.notes.begin(), dev.notes.end());
  if (dev.framesLeftOut > 0) {
    auto first = std::find_if(dev.frames.begin(), dev.frames.end(), [](const auto& f) { return f.second.leftOut; });
    notes.push_back(std::to_string(dev.framesLeftOut) + " frames of the window (the first: frame " +
                    std::to_string(first == dev.frames.end() ? 0 : first->first) +
                    ") ran command buffers recorded outside it, whose draws and dispatches were not counted: they are left out, "
                    "and the window went on for as many more frames");
  }
  out["notes"] = json(std::move(notes));
  out["frames"] = std::move(frames);
  return out;
}

}  // namespace tally::layer
