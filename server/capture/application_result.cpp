// The layer's output file, read into the capture result of one run whose
// samples are the layer's frames (docs/result-schema.md, "Applications").
#include "capture/application.hpp"

#include <cstdint>
#include <optional>
#include <stdexcept>

#include "common/json_fields.hpp"
#include "common/version.hpp"

namespace tally::capture {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr size_t kMaxSceneChars = 120;  // the run's scene: the command line, shortened

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

// A pass's "sites" (TALLY_LAYER_SITES): each entry checked as a line is,
// its source position and instruction where the module had them.
json sitesOf(const json& sites, const std::string& path) {
  json out = json::array();
  for (size_t i = 0; i < sites.size(); ++i) {
    const std::string where = path + "[" + std::to_string(i) + "]";
    const json& site = sites[i];
    if (!site.is_object()) malformed(where, "must be an object");
    json line = lineOf({{"name", kMembers.text(site, "resource", where)},
                        {"access", kMembers.text(site, "access", where)},
                        {"kind", kMembers.optText(site, "kind", where).value_or("")},
                        {"count", site.contains("count") ? site["count"] : json()},
                        {"bytes", site.contains("bytes") ? site["bytes"] : json()}},
                       where);
    json entry = {{"shader", kMembers.optText(site, "shader", where).value_or("")},
                  {"stage", kMembers.optText(site, "stage", where).value_or("")},
                  {"entry_point", kMembers.optText(site, "entry_point", where).value_or("")},
                  {"function", kMembers.optText(site, "function", where).value_or("")},
                  {"opcode", kMembers.optText(site, "opcode", where).value_or("")},
                  {"disassembly", kMembers.optText(site, "disassembly", where).value_or("")},
                  {"resource", line["name"]},
                  {"access", line["access"]},
                  {"kind", line["kind"]},
                  {"count", line["count"]},
                  {"bytes", line["bytes"]},
                  {"file", nullptr},
                  {"line", nullptr}};
    if (auto instruction = kMembers.optInteger(site, "instruction", where)) entry["instruction"] = *instruction;
    if (auto file = kMembers.optText(site, "file", where)) entry["file"] = *file;
    if (auto number = kMembers.optInteger(site, "line", where)) {
      if (*number < 1) malformed(at(where, "line"), "must be at least 1");
      entry["line"] = *number;
    }
    out.push_back(std::move(entry));
  }
  return out;
}

// A draw's bytes as the built-in renderers' captures give them (capture/sample.cpp).
json drawAmounts(json entry, const json& draw, const std::string& where) {
  const double count = kMembers.number(draw, "count", where), read = kMembers.number(draw, "bytes_read", where),
               written = kMembers.number(draw, "bytes_written", where);
  if (count < 0 || read < 0 || written < 0) malformed(where, "count and bytes must not be negative");
  entry["count"] = count;
  entry["bytes_read"] = read;
  entry["bytes_written"] = written;
  entry["bytes"] = read + written;
  return entry;
}

// The layer's "draw_list" (TALLY_LAYER_DRAWS) as the pass's "draws", and its
// "draws_rest": the shape of the built-in renderers' per-draw counts.
void drawsOf(const json& pass, const std::string& path, json& out) {
  json draws = json::array();
  const json& list = kMembers.array(pass, "draw_list", path);
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string where = item(path, "draw_list", i);
    if (!list[i].is_object()) malformed(where, "must be an object");
    const auto index = kMembers.integer(list[i], "index", where);
    if (index < 0) malformed(at(where, "index"), "must not be negative");
    draws.push_back(drawAmounts({{"index", index}, {"name", kMembers.text(list[i], "name", where)}}, list[i], where));
  }
  out["draws"] = std::move(draws);
  if (const json* rest = find(pass, "draws_rest")) {
    const std::string where = at(path, "draws_rest");
    if (!rest->is_object()) malformed(where, "must be an object");
    const auto commands = kMembers.integer(*rest, "draws", where);
    if (commands < 1) malformed(at(where, "draws"), "must be at least 1");
    out["draws_rest"] = drawAmounts({{"draws", commands}}, *rest, where);
  }
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
  // "draw_count": the draw commands; "draws" too, unless the per-draw list takes its place.
  if (draws) out["draws"] = out["draw_count"] = *draws;
  if (find(pass, "draw_list")) drawsOf(pass, path, out);
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
  if (find(pass, "sites")) out["sites"] = sitesOf(kMembers.array(pass, "sites", path), at(path, "sites"));
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

// Nothing counted: the layer could not count on this device, or every
// pipeline layout of the application uses every descriptor set (the
// application ran unchanged, but there is nothing to store).
std::optional<std::string> countedNothing(const json& layer) {
  if (find(layer, "counting_enabled") && layer["counting_enabled"] == false) {
    return "the layer counted nothing: " +
           (find(layer, "not_counting") && layer["not_counting"].is_string() ? layer["not_counting"].get<std::string>()
                                                                             : std::string("counting was off"));
  }
  if (find(layer, "pipelines_counted") && layer["pipelines_counted"] == 0 && find(layer, "layouts_refused") &&
      layer["layouts_refused"].is_number_unsigned() && layer["layouts_refused"].get<uint64_t>() > 0) {
    return "the layer counted nothing: every pipeline of the application has a layout that uses every "
           "descriptor set the device allows (" +
           std::to_string(layer["layouts_refused"].get<uint64_t>()) +
           " layouts refused; the layer needs the last set for its counters), so its pipelines ran "
           "unchanged and uncounted";
  }
  return std::nullopt;
}

// Resources, and the render targets' total as a renderer's run has it.
json resourcesOf(const json& output, std::optional<int64_t>& renderTargets) {
  json resources = json::array();
  const json& resourceList = kMembers.array(output, "resources", "");
  for (size_t i = 0; i < resourceList.size(); ++i) {
    json r = resourceOf(resourceList[i], item("", "resources", i));
    const std::string kind = r["kind"].get<std::string>();
    if ((kind == "attachment" || kind == "depth") && r.contains("allocation_bytes")) {
      renderTargets = renderTargets.value_or(0) + r["allocation_bytes"].get<int64_t>();
    }
    resources.push_back(std::move(r));
  }
  return resources;
}

// The layer's own notes, each a string.
json layerNotesOf(const json& output) {
  json layerNotes = json::array();
  const json& noteList = kMembers.array(output, "notes", "");
  for (size_t i = 0; i < noteList.size(); ++i) {
    if (!noteList[i].is_string()) malformed(item("", "notes", i), "must be a string");
    layerNotes.push_back(noteList[i]);
  }
  return layerNotes;
}

}  // namespace

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
    if (auto nothing = countedNothing(layer)) return makeError(*nothing);
    const json& frames = kMembers.array(output, "frames", "");
    if (frames.empty()) malformed("frames", "missing or empty: no frame was read back");
    const bool complete = find(output, "complete") ? output["complete"] == true : true;
    if (frames.size() < spec.frames) {
      return makeError("only " + std::to_string(frames.size()) + " of the " + std::to_string(spec.frames) +
                       " frames asked for arrived" +
                       (complete ? "" : " (the layer's output says complete: false: the application tore its device down first)"));
    }

    std::optional<int64_t> renderTargets;
    json resources = resourcesOf(output, renderTargets);

    json notes = json::object();
    const auto [width, height] = extentOf(output, resources, notes);

    bool untimed = false;
    json samples = samplesOf(frames, spec, untimed);

    json uninstrumented = uninstrumentedOf(output);
    json layerNotes = layerNotesOf(output);

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

}  // namespace tally::capture
