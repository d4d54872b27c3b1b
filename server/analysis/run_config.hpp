// What a run measured, as the accuracy and repeatability figures compare
// runs: read from a capture result here, and from stored runs by reports/
// (reports/run_rows.hpp). Two runs measure the same frames only when all of
// these agree (and their cameras and frames, which the callers compare).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"

namespace tally::analysis {

struct RunConfig {
  std::string id;  // the run's id or position, echoed back
  std::string renderer, scene, sceneParams, device, counting;
  // The renderer's canonical options as JSON text ("{}" for none): variants
  // of one renderer never measure the same frames.
  std::string options = "{}";
  int width = 0, height = 0, lights = 0;
};

// The runs of a capture result with the result's device name, one
// RunConfig per run (id: the run's position), or an error naming what is missing.
struct ResultRun {
  RunConfig config;
  const nlohmann::json* run = nullptr;  // the run's JSON, with a "samples" array
};
Result<std::vector<ResultRun>> resultRuns(const nlohmann::json& result);

// A camera without its index and label: equal cameras, equal text.
std::string cameraKey(const nlohmann::json& camera);

// One counter line of a result's pass: "pass/resource access".
std::string lineKey(const nlohmann::json& pass, const nlohmann::json& line);

}  // namespace tally::analysis
