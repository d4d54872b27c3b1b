#include "analysis/run_config.hpp"

namespace tally::analysis {
namespace {

using nlohmann::json;

std::string text(const json& j, const char* key) {
  if (!j.contains(key) || j[key].is_null()) return "";
  return j[key].is_string() ? j[key].get<std::string>() : j[key].dump();
}

}  // namespace

Result<std::vector<ResultRun>> resultRuns(const json& result) {
  if (!result.is_object() || !result.contains("runs") || !result["runs"].is_array()) {
    return makeError("not a capture result: no \"runs\" array");
  }
  std::string device = result.contains("device") && result["device"].is_object() ? text(result["device"], "name") : "";
  std::vector<ResultRun> out;
  for (size_t i = 0; i < result["runs"].size(); ++i) {
    const json& r = result["runs"][i];
    if (!r.is_object() || !r.contains("samples") || !r["samples"].is_array()) {
      return makeError("runs[" + std::to_string(i) + "]: no samples");
    }
    RunConfig c;
    c.id = std::to_string(i);
    c.renderer = text(r, "renderer");
    c.options = r.contains("options") && r["options"].is_object() ? r["options"].dump() : "{}";
    c.scene = text(r, "scene");
    c.sceneParams = r.contains("scene_params") ? r["scene_params"].dump() : "";
    c.device = device;
    c.counting = r.contains("counting") ? text(r, "counting") : "exact";
    c.width = r.value("width", 0);
    c.height = r.value("height", 0);
    c.lights = r.value("lights", 0);
    out.push_back({std::move(c), &r});
  }
  return out;
}

std::string cameraKey(const json& cameraJson) {
  json camera = cameraJson.is_object() ? cameraJson : json::object();
  camera.erase("index");
  camera.erase("label");
  return camera.dump();
}

std::string lineKey(const json& pass, const json& line) {
  return pass.value("name", "") + "/" + line.value("name", "") + " " + line.value("access", "");
}

}  // namespace tally::analysis
