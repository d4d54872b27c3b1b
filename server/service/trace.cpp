#include "service/trace.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace tally::service {

using nlohmann::json;

namespace {

constexpr int kPid = 1;
constexpr int kGpuTid = 1;

// Milliseconds -> whole nanoseconds (never negative).
int64_t nanos(double ms) {
  if (!std::isfinite(ms) || ms <= 0) return 0;
  return static_cast<int64_t>(std::llround(ms * 1e6));
}

// Nanoseconds -> the format's microseconds.
double micros(int64_t ns) { return static_cast<double>(ns) / 1000.0; }

std::string processName(const store::RunRow& run) {
  std::string name = run.variant.empty() ? run.renderer : run.variant;
  name += " " + run.scene + " " + std::to_string(run.width) + "x" + std::to_string(run.height);
  if (!run.deviceName.empty()) name += " on " + run.deviceName;
  if (run.host) name += " (" + *run.host + ")";
  return name;
}

// A pass's heaviest source lines, for its slice's args: where in the shader its bytes go.
json topLinesJson(const std::vector<store::SiteRow>& lines, double passBytes) {
  json out = json::array();
  for (const auto& line : lines) {
    out.push_back({{"shader", line.shader},
                   {"line", line.line ? json(*line.line) : json(nullptr)},
                   {"instruction", line.instruction ? json(*line.instruction) : json(nullptr)},
                   {"bytes", line.bytes},
                   {"share", passBytes > 0 ? json(line.bytes / passBytes) : json(nullptr)},
                   {"resources", line.resources}});
  }
  return out;
}

}  // namespace

json sampleTrace(const store::RunRow& run, const store::Sample& sample,
                 const std::map<int, std::vector<store::SiteRow>>& topLines) {
  const store::SampleRow& row = sample.row;
  // Frames: the stored per-frame times, else the sample's frame count at its median.
  size_t frames = row.frameMsFrames.size();
  bool measured = frames > 0;
  for (const auto& pass : sample.passes) {
    if (pass.gpuMsFrames.size() != frames) measured = false;
  }
  if (!measured) frames = row.frames && *row.frames > 0 ? static_cast<size_t>(*row.frames) : 1;
  auto frameMs = [&](size_t f) { return measured ? row.frameMsFrames[f] : row.frameMs; };
  auto passMs = [&](const store::Pass& pass, size_t f) { return measured ? pass.gpuMsFrames[f] : pass.gpuMs; };

  // Bytes per frame per resource (read + write, over every pass), by first appearance.
  std::vector<std::string> resources;
  std::map<std::string, double> bytesByResource;
  for (const auto& pass : sample.passes) {
    for (const auto& counter : pass.counters) {
      if (!bytesByResource.count(counter.resource)) resources.push_back(counter.resource);
      bytesByResource[counter.resource] += counter.bytes;
    }
  }

  json events = json::array();
  events.push_back({{"name", "process_name"}, {"ph", "M"}, {"pid", kPid}, {"tid", kGpuTid}, {"ts", 0},
                    {"args", {{"name", processName(run)}}}});
  events.push_back({{"name", "thread_name"}, {"ph", "M"}, {"pid", kPid}, {"tid", kGpuTid}, {"ts", 0},
                    {"args", {{"name", "GPU"}}}});

  int clipped = 0;
  int64_t frameStart = 0;
  for (size_t f = 0; f < frames; ++f) {
    int64_t frameDur = nanos(frameMs(f));
    int64_t frameEnd = frameStart + frameDur;
    events.push_back({{"name", "frame " + std::to_string(f)},
                      {"cat", "frame"},
                      {"ph", "X"},
                      {"pid", kPid},
                      {"tid", kGpuTid},
                      {"ts", micros(frameStart)},
                      {"dur", micros(frameDur)},
                      {"args", {{"frame", f}, {"frame_ms", frameMs(f)}}}});
    int64_t passStart = frameStart;
    for (size_t p = 0; p < sample.passes.size(); ++p) {
      const store::Pass& pass = sample.passes[p];
      double ms = passMs(pass, f);
      int64_t dur = nanos(ms);
      if (passStart + dur > frameEnd) {
        dur = std::max<int64_t>(0, frameEnd - passStart);
        ++clipped;
      }
      double bytes = 0;
      for (const auto& counter : pass.counters) bytes += counter.bytes;
      json args = {{"frame", f}, {"gpu_ms", ms}, {"bytes", bytes}};
      if (auto lines = topLines.find(static_cast<int>(p)); lines != topLines.end()) {
        args["top_lines"] = topLinesJson(lines->second, bytes);
      }
      events.push_back({{"name", pass.name},
                        {"cat", "pass"},
                        {"ph", "X"},
                        {"pid", kPid},
                        {"tid", kGpuTid},
                        {"ts", micros(passStart)},
                        {"dur", micros(dur)},
                        {"args", std::move(args)}});
      passStart += dur;
    }
    for (const auto& resource : resources) {
      events.push_back({{"name", "bytes " + resource},
                        {"cat", "bytes"},
                        {"ph", "C"},
                        {"pid", kPid},
                        {"tid", kGpuTid},
                        {"ts", micros(frameStart)},
                        {"args", {{"bytes", bytesByResource[resource]}}}});
    }
    frameStart = frameEnd;
  }

  json metadata = {{"source", "tally"},
                   {"sample", row.id},
                   {"run", run.id},
                   {"renderer", run.renderer},
                   {"variant", run.variant.empty() ? run.renderer : run.variant},
                   {"scene", run.scene},
                   {"width", run.width},
                   {"height", run.height},
                   {"counting", run.counting},
                   {"device", run.deviceName},
                   {"host", run.host ? json(*run.host) : json(nullptr)},
                   {"camera_index", row.cameraIndex},
                   {"frames", frames},
                   {"frame_ms", row.frameMs},
                   {"frame_times", measured ? "measured" : "medians"},
                   {"clipped_passes", clipped},
                   {"bytes", "counter tracks: requested bytes per frame of each resource, read + write, "
                             "summed over passes (the counted frames' average, the same every frame)"}};
  if (!topLines.empty()) {
    metadata["top_lines"] = "pass slices' args.top_lines: the pass's heaviest source lines (shader, line, bytes per "
                            "frame, share of the pass's bytes, resource lines), from its per-site counts";
  }
  return {{"traceEvents", std::move(events)}, {"displayTimeUnit", "ms"}, {"metadata", std::move(metadata)}};
}

}  // namespace tally::service
