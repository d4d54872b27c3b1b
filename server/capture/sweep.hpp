// Stability sweeps: capture kinds that vary one numeric parameter of a method
// until it breaks, and state where it does. Every sweep spec has the frame
// {"sweep": NAME, ...} and every result the shape
//   {"sweep": NAME, "parameters": [...], "points": [{<param>: value, ...,
//    "error": {...}}], "threshold": {...}, "fails_at": {...} | null,
//    "device": {...}, "spec": {...}}
// (docs/result-schema.md, "Sweep results"). `tallyd capture --spec` sends a
// spec with "sweep" here instead of to the capture matrix.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/counter_sweep.hpp"
#include "capture/depth_sweep.hpp"
#include "capture/edges_sweep.hpp"
#include "capture/id_sweep.hpp"
#include "capture/precision_sweep.hpp"
#include "capture/runner.hpp"
#include "common/result.hpp"

namespace tally::capture {

// One alternative per sweep kind.
using SweepSpec = std::variant<DepthSweepSpec, IdSweepSpec, EdgesSweepSpec, PrecisionSweepSpec, CounterSweepSpec>;

// "depth-reconstruction", "id-capacity", "material-edges", "visbuffer-precision", "counter-headroom"
std::vector<std::string> sweepNames();

bool isSweepSpec(const nlohmann::json& spec);  // an object with "sweep"

// Errors name the field: "sweep: unknown sweep 'x' (expected one of ...)".
Result<SweepSpec> parseSweepSpec(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers);

Result<nlohmann::json> runSweep(const SweepSpec& spec, const CaptureOptions& options);

}  // namespace tally::capture
